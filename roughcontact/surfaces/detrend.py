"""Removal of the mean height or of the mean plane of a topography.

Measured topographies carry an arbitrary height offset and a tilt of the
specimen in the instrument; neither is roughness. The mean plane is the
least-squares plane ``h ≈ c + a x + b y`` over the footprint nodes (ISO
25178 "F-operation" by a plane).
"""
from __future__ import annotations

import numpy as np

from ..checks import check_choice
from .statistics import valid_nodes
from .topography import Topography

MODES = ("mean", "plane")


def detrend(topography: Topography, mode: str = "plane") -> Topography:
    """The topography minus its footprint mean or mean plane.

    Parameters
    ----------
    topography
        Heights; only footprint nodes enter the fit.
    mode
        ``"mean"``: subtract the mean height. ``"plane"``: subtract the
        least-squares plane.

    Returns
    -------
    Topography
        Same grid and footprint; ``metadata["detrend"]`` records the mode and
        the removed coefficients (offset m, slopes a = ∂h/∂x and b = ∂h/∂y).
    """
    mode = check_choice("mode", mode, MODES)
    heights, coefficients = _detrended(topography.heights, topography.spacing, valid_nodes(topography), mode)
    meta = dict(topography.metadata)
    meta["detrend"] = dict(mode=mode, **coefficients)
    return Topography(heights, topography.spacing, topography.footprint, meta)


def _detrended(heights: np.ndarray, spacing: float, mask: np.ndarray, mode: str):
    if mode == "mean":
        offset = float(heights[mask].mean())
        return heights - offset, dict(offset=offset)
    x = np.arange(heights.shape[0])[:, None] * spacing
    y = np.arange(heights.shape[1])[None, :] * spacing
    xs, ys = np.broadcast_to(x, heights.shape)[mask], np.broadcast_to(y, heights.shape)[mask]
    # centred coordinates keep the normal equations well conditioned
    xc, yc = xs.mean(), ys.mean()
    design = np.column_stack([np.ones(xs.size), xs - xc, ys - yc])
    (c, a, b), *_ = np.linalg.lstsq(design, heights[mask], rcond=None)
    plane = c + a * (x - xc) + b * (y - yc)
    return heights - plane, dict(offset=float(c - a * xc - b * yc), slope_x=float(a), slope_y=float(b))
