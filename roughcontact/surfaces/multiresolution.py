"""The same surface at spacings s, 2s, 4s, … for the multiscale analysis (§3.2, Fig. 1).

Fig. 1 of the paper solves one interface at several discretisations s and
finds the real contact area shrinking as the resolution increases. Two ways
to coarsen a grid by an integer factor f:

- **decimation** keeps every f-th node: the coarse surface is the fine one
  sampled at spacing f s (what a coarser instrument would have recorded at
  those points; for a midpoint-displacement surface without random additions
  it is exactly the surface of an earlier refinement level).
- **local averaging** replaces each block of f × f nodes by its mean, at the
  block centre: each coarse punch of side f s carries the mean height of the
  area it represents (the coarse grid's origin moves by (f − 1) s / 2).
"""
from __future__ import annotations

import numpy as np

from ..checks import check_choice, check_integer
from ..errors import InputError
from .topography import Topography

METHODS = ("decimate", "average")


def coarsen(topography: Topography, factor: int, method: str = "decimate") -> Topography:
    """The topography on a grid of spacing ``factor * s``.

    Parameters
    ----------
    topography
        Fine surface.
    factor
        Integer coarsening factor f >= 1.
    method
        ``"decimate"``: nodes (f i, f j), all kept nodes, footprint decimated
        alike. ``"average"``: means over blocks of f × f nodes; rows and
        columns left over at the far edges are dropped; a block belongs to the
        footprint only if all its nodes do.

    Returns
    -------
    Topography
        ``metadata["coarsening"]`` records method, factor, the origin (m) of
        the first coarse node in the fine frame and the dropped nodes.
    """
    factor = check_integer("factor", factor, 1)
    method = check_choice("method", method, METHODS)
    nx, ny = topography.shape
    s = topography.spacing
    if method == "decimate":
        heights = topography.heights[::factor, ::factor]
        footprint = topography.footprint[::factor, ::factor]
        origin = 0.0
        dropped = ((nx - 1) % factor, (ny - 1) % factor)
    else:
        mx, my = nx // factor, ny // factor
        if mx < 1 or my < 1:
            raise InputError("factor", f"blocks of {factor} nodes do not fit in a {nx} x {ny} grid")
        inside = topography.footprint[: mx * factor, : my * factor].reshape(mx, factor, my, factor)
        footprint = inside.all(axis=(1, 3))
        block = topography.heights[: mx * factor, : my * factor].reshape(mx, factor, my, factor)
        block = np.where(inside, block, 0.0)  # NaN off the footprint must not leak into kept blocks
        heights = np.where(footprint, block.mean(axis=(1, 3)), np.nan)
        origin = (factor - 1) * s / 2.0
        dropped = (nx - mx * factor, ny - my * factor)
    if not footprint.any():
        raise InputError("factor", f"coarsening by {factor} leaves no node of the footprint")
    meta = dict(topography.metadata)
    meta["coarsening"] = dict(method=method, factor=factor, origin=(origin, origin),
                              dropped_nodes=dropped, fine_spacing=s)
    return Topography(heights, factor * s, footprint, meta)


def multiresolution(topography: Topography, levels: int, method: str = "decimate") -> list[Topography]:
    """The topography at spacings s, 2s, 4s, …, 2**(levels − 1) s.

    Every level is coarsened directly from the finest grid (for decimation
    and for averaging over whole blocks this equals repeated halving).

    Parameters
    ----------
    topography
        Finest surface, spacing s.
    levels
        Number of resolutions, >= 1.
    method
        ``"decimate"`` or ``"average"`` (see :func:`coarsen`).
    """
    levels = check_integer("levels", levels, 1)
    method = check_choice("method", method, METHODS)
    if 2 ** (levels - 1) > max(topography.shape):
        raise InputError("levels", f"{levels} levels need a coarsening by {2 ** (levels - 1)}, "
                         f"more than the grid {topography.shape} holds")
    return [topography if k == 0 else coarsen(topography, 2**k, method) for k in range(levels)]
