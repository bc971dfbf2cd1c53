"""Footprints: the nodes of the grid that belong to the nominal contact region.

A footprint is a boolean mask of the same shape as the height array. The paper's
rock joint is the circular section of a 50 mm cylindrical core (§3.4); synthetic
surfaces use the whole rectangle.
"""
from __future__ import annotations

import numpy as np

from ..checks import check_shape, require_finite_positive
from ..errors import InputError


def rectangle(shape: tuple[int, int]) -> np.ndarray:
    """All nodes of a grid of ``shape`` = (nx, ny)."""
    nx, ny = check_shape(shape, minimum=1)
    return np.ones((nx, ny), dtype=bool)


def disc(shape: tuple[int, int], spacing: float, diameter: float,
         centre: tuple[float, float] | None = None) -> np.ndarray:
    """Nodes within a disc of ``diameter`` (m), e.g. the section of a core.

    Node (i, j) sits at (i s, j s). The disc is centred on ``centre`` (m),
    by default the centre of the grid. A node belongs to the disc when its
    distance to the centre is at most ``diameter / 2``.
    """
    nx, ny = check_shape(shape, minimum=1)
    s = require_finite_positive("spacing", spacing)
    d = require_finite_positive("diameter", diameter)
    if centre is None:
        centre = ((nx - 1) * s / 2.0, (ny - 1) * s / 2.0)
    x = np.arange(nx)[:, None] * s - centre[0]
    y = np.arange(ny)[None, :] * s - centre[1]
    mask = x**2 + y**2 <= (d / 2.0) ** 2 * (1.0 + 1e-12)
    if not mask.any():
        raise InputError("diameter", f"a disc of diameter {d} m holds no node of the grid")
    return mask
