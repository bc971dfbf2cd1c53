#!/usr/bin/env python
"""The error of the uncoupled Cattaneo model against the coupled solve, charted over ν and Q/fP.

For two identical bodies (β = 0, γ = ν/(1 − ν), Eq. 4b) the uncoupled model
(Eqs. 21–24, the γ terms of Eqs. 15–16 dropped) and the coupled solve
(:mod:`roughcontact.tangential.coupled`) share the normal solution at a
given load P (load control: the pressure does not depend on ν, only the
approach does). Both sweep Q = k fP/N; at each Q/fP the relative error of
the uncoupled stick area, δx, E_f and Q_stick (Q_stick's as a fraction of
fP, since it vanishes near fP) and the distance between the two centroids
of shear G_Q (in grid spacings) are recorded, for a Hertz contact and
random-midpoint rough surfaces with Δ = 2.1, 2.3, 2.5.

    python scripts/chart_uncoupled_error.py          # results/uncoupled_error.json and .png
    python scripts/chart_uncoupled_error.py --level 5 --steps 5   # a quicker look
"""
from __future__ import annotations

import argparse
import math
import time
import warnings
from pathlib import Path

import numpy as np

from _ranks import save_json

METRICS = {
    "stick_area": "stick area, relative error",
    "approach": "δx, relative error",
    "frictional_energy": "E_f, relative error",
    "stick_force": "Q_stick error / fP",
    "centroid": "|ΔG_Q| / s",
}


def errors(uncoupled, coupled, spacing: float) -> dict[str, float]:
    """Errors of one uncoupled state against the coupled one at the same Q."""
    fp = coupled.friction * coupled.normal.load
    gap = math.hypot(uncoupled.centroid[0] - coupled.centroid[0], uncoupled.centroid[1] - coupled.centroid[1])
    return {
        "stick_area": uncoupled.stick_area / coupled.stick_area - 1.0 if coupled.stick_area else math.nan,
        "approach": uncoupled.tangential_approach / coupled.tangential_approach - 1.0,
        "frictional_energy": uncoupled.frictional_energy / coupled.frictional_energy - 1.0,
        "stick_force": (uncoupled.stick_force - coupled.stick_force_along) / fp,
        "centroid": gap / spacing,
    }


def surfaces(level: int):
    """(name, topography, load P, friction f) of each case, on 2^level + 1 nodes a side."""
    from roughcontact.surfaces import Topography, midpoint_surface

    n = 2**level + 1
    spacing = 50e-6 / ((n - 1) / 2.4)                 # a = 50 µm spans 2.4 a / s nodes
    x = (np.arange(n) - (n - 1) / 2) * spacing
    sphere = -(x[:, None] ** 2 + x[None, :] ** 2) / (2 * 0.01)     # Δh = −r²/(2R), R = 10 mm
    yield "hertz", Topography(sphere, spacing), None, 0.5
    for dimension in (2.1, 2.3, 2.5):
        yield (f"rough D={dimension}", midpoint_surface(level, dimension, spacing=1e-4, rms_height=1e-5, seed=3),
               100.0, 0.6)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, default=6, help="grid of 2^level + 1 nodes a side (6: 65²)")
    parser.add_argument("--steps", type=int, default=10, help="Q = k fP / steps")
    parser.add_argument("--nu", type=float, nargs="+", default=[0.0, 0.1, 0.2, 0.3, 0.4, 0.5])
    parser.add_argument("--output", default="results/uncoupled_error.json")
    args = parser.parse_args()

    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import ActiveSetSolver, NormalProblem
    from roughcontact.tangential import UncoupledApproximationWarning, tangential_sweep
    from roughcontact.tangential.coupled import coupled_sweep

    warnings.simplefilter("ignore", UncoupledApproximationWarning)
    comm = MPI.COMM_WORLD
    rows = []
    for name, topography, load, friction in surfaces(args.level):
        for nu in args.nu:
            interface = Interface(Material(20e9, nu), Material(20e9, nu))
            problem = NormalProblem(topography, interface, comm)
            try:
                with ActiveSetSolver(problem) as solver:
                    normal = solver.solve_load(load) if load else solver.solve_closure(50e-6**2 / 0.01)
                t0 = time.perf_counter()
                uncoupled = tangential_sweep(problem, normal, friction, steps=args.steps, method="ksp",
                                             include_limit=False)
                t1 = time.perf_counter()
                coupled = coupled_sweep(problem, normal, friction, steps=args.steps)
                t2 = time.perf_counter()
            finally:
                problem.destroy()
            for u, c in zip(uncoupled.states[1:], coupled.states[1:]):
                row = {"case": name, "nu": nu, "gamma": interface.composite_poisson,
                       "Q_over_fP": round(u.load_ratio, 6), "grid": list(topography.shape),
                       "contact_nodes": int(normal.contact.sum()), **errors(u, c, topography.spacing),
                       "cross_traction": float(np.abs(c.cross_traction).max() / (friction * normal.force.max())),
                       "uncoupled_seconds": t1 - t0, "coupled_seconds": t2 - t1}
                rows.append(row)
            worst = {k: max(abs(r[k]) for r in rows[-(args.steps - 1):]) for k in METRICS}
            print(f"{name:12s} nu={nu:.2f} " + " ".join(f"{k}={v:.3g}" for k, v in worst.items())
                  + f"  ({t1 - t0:.2f} s uncoupled, {t2 - t1:.2f} s coupled)", flush=True)
    out = save_json({"metrics": METRICS, "level": args.level, "steps": args.steps, "rows": rows}, args.output)
    chart(rows, args.nu, out.with_suffix(".png"))


def chart(rows: list[dict], nus: list[float], path: Path) -> None:
    """One panel per metric: the largest |error| over Q/fP against ν, one line per case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(1, len(METRICS), figsize=(4 * len(METRICS), 3.4), constrained_layout=True)
    for ax, (key, label) in zip(axes, METRICS.items()):
        for case in cases:
            worst = [max(abs(r[key]) for r in rows if r["case"] == case and r["nu"] == nu) for nu in nus]
            ax.plot(nus, worst, marker="o", label=case)
        ax.set_xlabel("ν (both bodies)")
        ax.set_title(label, fontsize=10)
    axes[0].set_ylabel("largest |error| over Q/fP")
    axes[0].legend(fontsize=8)
    fig.suptitle("uncoupled Cattaneo model against the coupled solve (β = 0)")
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
