"""The analyses that need the flexibility operator or the solver (PETSc).

Only ``createVecs`` and ``mult`` of the operator are used, so a matrix-free
operator with the same ``Mat`` interface serves as well as the dense one.
Collective over the problem's communicator; results are identical on every
rank.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from ..checks import require_finite_positive
from ..errors import InputError
from ..materials import Interface
from ..normal.problem import NormalProblem
from ..surfaces.topography import Topography


@dataclass(frozen=True)
class BulkCompliance:
    """Displacement of the footprint under a uniform pressure of unit resultant (m/N).

    Attributes
    ----------
    mean
        Mean displacement over the footprint, the work-conjugate approach:
        P δ = Σ p̄_i u_i with equal p̄_i. The closure's bulk part is ``mean`` P.
    centre
        Displacement of the footprint node nearest its centroid.
    displacement
        The displacement per unit load at every node, (nx, ny), NaN off the footprint.
    """

    mean: float
    centre: float
    displacement: np.ndarray


def bulk_compliance(problem: NormalProblem) -> BulkCompliance:
    """u = H p̄ for p̄ = 1/N on each of the N footprint nodes (unit total load), through ``problem.operator``.

    This is the bulk deformation of §3.3 ("uniform pressure on the nominal
    loaded area") computed with the same operator as the solve, so
    δz − ``mean`` P removes it exactly for the discretisation.
    """
    forces, displacement = problem.operator.createVecs()
    try:
        forces.set(1.0 / problem.size)
        problem.operator.mult(forces, displacement)
        values = problem.gather(displacement.getArray().copy())
    finally:
        forces.destroy()
        displacement.destroy()
    nearest = problem.nearest_node((0.0, 0.0))
    return BulkCompliance(float(values.mean()), float(values[nearest]), problem.to_field(values, fill=np.nan))


def footprint_bulk_compliance(footprint: np.ndarray, spacing: float, interface: Interface, comm) -> BulkCompliance:
    """:func:`bulk_compliance` of a footprint alone (flat heights), its problem built and freed here."""
    topography = Topography(np.zeros(np.shape(footprint)), spacing, np.asarray(footprint, dtype=bool))
    problem = NormalProblem(topography, interface, comm)
    try:
        return bulk_compliance(problem)
    finally:
        problem.destroy()


def solve_resolutions(topography: Topography, interface: Interface, comm, load: float, levels: int,
                      method: str = "decimate", solver: str = "auto") -> xr.Dataset:
    """The real contact area at one load P on the same surface at s, 2s, 4s, … (Fig. 1).

    Each resolution of :func:`~roughcontact.surfaces.multiresolution` is
    solved under load control; the dataset has the dimension ``spacing``
    with ``contact_area``, ``contact_fraction`` and ``contact_nodes``, the
    input of :func:`~.resolution.contact_area_resolution`.
    """
    from ..normal import make_solver
    from ..surfaces import multiresolution

    load = require_finite_positive("load", load)
    rows = []
    for coarse in reversed(multiresolution(topography, levels, method)):
        problem = NormalProblem(coarse, interface, comm)
        try:
            with make_solver(problem, solver) as normal_solver:
                result = normal_solver.solve_load(load)
        finally:
            problem.destroy()
        rows.append((coarse.spacing, result.contact_area, result.contact_fraction, result.contact_count))
    if any(r[3] == 0 for r in rows):
        raise InputError("load", f"P = {load:g} N leaves a resolution without contact")
    spacing, area, fraction, count = (np.array(c) for c in zip(*rows))
    return xr.Dataset(
        {"contact_area": ("spacing", area, {"units": "m2", "long_name": "real contact area A_r"}),
         "contact_fraction": ("spacing", fraction, {"units": "1", "long_name": "A_r / A_0"}),
         "contact_nodes": ("spacing", count, {"units": "1", "long_name": "nodes in contact"}),
         "normal_load": ((), load, {"units": "N", "long_name": "normal load P (Eq. 8)"})},
        coords={"spacing": ("spacing", spacing, {"units": "m", "long_name": "grid spacing s"})},
        attrs={"coarsening": method})
