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

from .. import analysis
from ..analysis.multifractal import multifractal_spectrum
from ..analysis.petsc import footprint_bulk_compliance
from ..analysis.report import interface_from_attrs
from ..references import hertz
from .results import PaperResults

#: the Hertz null of Fig. 14: a 257² grid, contact radius 64 nodes, moments q ∈ [−5, 5]
HERTZ_NODES, HERTZ_RADIUS_NODES = 257, 64


def contact_dimensions(results: PaperResults, key: str) -> xr.DataArray:
    """Δσ of every contact set of study ``key`` (undefined sets NaN), computed once per report."""
    ds = results.root[key]
    load_dim = ds.attrs.get("load_dimension", "normal_load")
    return results.cached(("contact_dimension", key), lambda: analysis.contact_dimension(
        ds, load_dim=load_dim, on_error="mark")["contact_dimension"])


def bulk_compliances(results: PaperResults, key: str) -> dict[int, float]:
    """c (m/N) of the footprint of each position along the study's first dimension (seeds share footprints).

    One operator per distinct footprint: the square grids of a Δ axis share one, each mated shift has its lens.
    """
    def compute():
        interface = interface_from_attrs(results.root[key].attrs)
        first_seed = {}
        for task in results.tasks(key):
            first_seed.setdefault(task.position[0], task)
        by_footprint, out = {}, {}
        for i in sorted(first_seed):
            topography = first_seed[i].topography()
            shape = (topography.footprint.shape, topography.spacing, topography.footprint.tobytes())
            if shape not in by_footprint:
                by_footprint[shape] = footprint_bulk_compliance(topography.footprint, topography.spacing, interface,
                                                                MPI.COMM_SELF).mean
            out[i] = by_footprint[shape]
        return out
    return results.cached(("bulk_compliance", key), compute)


def footprint_centres(results: PaperResults, key: str) -> tuple[xr.DataArray, xr.DataArray]:
    """Centroid C (m) of each task's footprint in its grid frame, on the study's dimensions."""
    def compute():
        ds = results.root[key]
        dims = ds["status"].dims
        cx = xr.full_like(ds["status"], np.nan, dtype=float)
        cy = xr.full_like(ds["status"], np.nan, dtype=float)
        for task in results.tasks(key):
            topography = task.topography()
            nodes = np.argwhere(topography.footprint) * topography.spacing
            cx[dict(zip(dims, task.position))] = nodes[:, 0].mean()
            cy[dict(zip(dims, task.position))] = nodes[:, 1].mean()
        return cx, cy
    return results.cached(("footprint_centre", key), compute)


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
