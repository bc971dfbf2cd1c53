"""The analysis figures of the default surface: solve, analyse, draw.

Solves the default study's surface (random midpoint displacement, Δ = 2.3,
65 × 65 nodes, two sandstone-like half-spaces) at its twelve loads and at
four resolutions under 100 N, then writes

- ``<output>/default-surface.nc`` and ``default-surface.analysis.nc`` with a
  figure per measure (``roughcontact analyse`` on the sweep),
- ``default-surface_resolution.png``: A_r against s with its exponent (Fig. 1d),

and prints the headline numbers. Run as
``.venv/bin/mpiexec -n 2 .venv/bin/python -m tools.analysis_figures [OUTPUT]``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

from roughcontact.analysis import contact_area_resolution
from roughcontact.analysis.command import analyse_file
from roughcontact.analysis.figures import power_law_figure
from roughcontact.analysis.petsc import solve_resolutions
from roughcontact.datasets import normal_sweep_dataset
from roughcontact.materials import Interface, Material
from roughcontact.netcdf import write_netcdf
from roughcontact.normal import NormalProblem, solve_loads
from roughcontact.surfaces import midpoint_surface

LOADS = np.linspace(25.0, 500.0, 12)


def main(output: Path, comm) -> None:
    say = print if comm.Get_rank() == 0 else (lambda *a: None)
    interface = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
    topography = midpoint_surface(6, 2.3, spacing=1e-4, rms_height=1e-5, seed=1)
    problem = NormalProblem(topography, interface, comm)
    try:
        results = solve_loads(problem, LOADS)
    finally:
        problem.destroy()
    sweep = normal_sweep_dataset(results, topography.spacing, attrs={"study": "default-surface",
                                                                     **interface.attrs()})
    path = write_netcdf(sweep, output / "default-surface.nc", comm)
    analyse_file(path, comm, output=output, log=say)
    resolutions = solve_resolutions(topography, interface, comm, 100.0, levels=4)
    fit = contact_area_resolution(resolutions)
    if comm.Get_rank() == 0:
        power_law_figure(resolutions["spacing"], resolutions["contact_area"], fit, "area_resolution_exponent",
                         output / "default-surface_resolution.png", title="A_r against s at P = 100 N")
        exponent = fit["area_resolution_exponent"]
        say(f"A_r ∝ s^m: m = {float(exponent):.3f} "
            f"[{float(fit['area_resolution_exponent_lower']):.3f}, {float(fit['area_resolution_exponent_upper']):.3f}]"
            f", Δσ = 2 − m = {float(fit['implied_dimension']):.3f}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("results/analysis"), MPI.COMM_WORLD)
