"""What the claims need beyond the study files: footprints rebuilt from the tasks, bulk compliances, Hertz.

A task's surface is rebuilt from its own definition (:meth:`Task.topography`,
cheap next to a solve): its footprint gives the bulk compliance c that the
closure curves remove (§3.3, one per footprint: the lens of each mated shift
is its own) and the centroid C from which the centroid paths are measured
(Fig. 11), both in the task's own grid frame, where the farm records G_P and
G_Q.
"""
from __future__ import annotations

import numpy as np
import xarray as xr
from mpi4py import MPI

from ..analysis.multifractal import multifractal_spectrum
from ..analysis.petsc import footprint_bulk_compliance
from ..analysis.report import interface_from_attrs
from ..references import hertz
from .results import PaperResults

#: the Hertz null of Fig. 14: a 257² grid, contact radius 64 nodes, moments q ∈ [−5, 5]
HERTZ_NODES, HERTZ_RADIUS_NODES = 257, 64


def _first_seed_tasks(results: PaperResults, key: str):
    """The first task (first seed) of each position of the study's first dimension."""
    seen = {}
    for task in results.tasks(key):
        seen.setdefault(task.position[0], task)
    return [seen[i] for i in sorted(seen)]


def bulk_compliances(results: PaperResults, key: str) -> dict[int, float]:
    """c (m/N) of the footprint of each position along the study's first dimension (seeds share footprints)."""
    interface = interface_from_attrs(results.root[key].attrs)
    out = {}
    for i, task in enumerate(_first_seed_tasks(results, key)):
        topography = task.topography()
        out[i] = footprint_bulk_compliance(topography.footprint, topography.spacing, interface, MPI.COMM_SELF).mean
    return out


def footprint_centres(results: PaperResults, key: str) -> tuple[xr.DataArray, xr.DataArray]:
    """Centroid C (m) of each task's footprint in its grid frame, on the study's dimensions."""
    ds = results.root[key]
    dims = tuple(d for d in ds["status"].dims)
    cx = xr.full_like(ds["status"], np.nan, dtype=float)
    cy = xr.full_like(ds["status"], np.nan, dtype=float)
    for task in results.tasks(key):
        topography = task.topography()
        nodes = np.argwhere(topography.footprint) * topography.spacing
        cx[dict(zip(dims, task.position))] = nodes[:, 0].mean()
        cy[dict(zip(dims, task.position))] = nodes[:, 1].mean()
    return cx, cy


def hertz_forces(nodes: int = HERTZ_NODES, radius_nodes: int = HERTZ_RADIUS_NODES) -> np.ndarray:
    """Nodal forces p(r) s² of a Hertz contact of radius ``radius_nodes`` centred on the grid (unit s, E*, P scale)."""
    centre = (nodes - 1) / 2.0
    i = np.arange(nodes) - centre
    r = np.hypot(i[:, None], i[None, :])
    radius = 1000.0 * radius_nodes      # sphere radius R = a² / d with d = a / 1000
    approach = radius_nodes**2 / radius
    return hertz.pressure(r, approach, radius, 1.0)


def hertz_spectrum() -> dict[str, float]:
    """Width and maximum of f(α) of :func:`hertz_forces`, q ∈ [−5, 5] (the null of Fig. 14)."""
    spectrum = multifractal_spectrum(hertz_forces(), q=np.linspace(-5.0, 5.0, 21))
    return {"width": float(spectrum["spectrum_width"]), "maximum": float(spectrum["spectrum_maximum"])}
