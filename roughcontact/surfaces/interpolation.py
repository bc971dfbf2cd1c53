"""Bilinear interpolation of heights on a regular grid, with missing data.

One helper serves two purposes: resampling non-square pixels onto a square
grid (measured files) and shifting a fracture face by a sub-pixel vector
(composite topographies, paper §3.4, Fig. 7).

Bilinear interpolation reproduces any bilinear function ``a + b x + c y + d x y``
exactly and returns node values exactly where the target falls on a node. It
smooths the shortest wavelengths (a half-pixel shift halves the amplitude at
the Nyquist wavelength); a value that would need a missing (NaN) node with a
nonzero weight is itself missing.
"""
from __future__ import annotations

import numpy as np

from ..checks import require_finite_positive
from ..errors import InputError

#: Fractional indices closer than this to an integer are snapped onto it, so
#: that shifts of whole pixels computed in floating point stay exact.
SNAP = 1e-9


def interpolate_at_indices(values: np.ndarray, index_x: np.ndarray, index_y: np.ndarray) -> np.ndarray:
    """Values at the tensor grid of fractional node indices (index_x, index_y).

    Parameters
    ----------
    values
        2-D array (nx, ny); NaN marks missing data.
    index_x, index_y
        1-D fractional indices along axis 0 and axis 1; targets outside
        [0, n − 1] are NaN.

    Returns
    -------
    numpy.ndarray
        Array (len(index_x), len(index_y)).
    """
    out = _along_axis(np.asarray(values, dtype=float), np.asarray(index_x, dtype=float), 0)
    return _along_axis(out, np.asarray(index_y, dtype=float), 1)


def resample_square(heights: np.ndarray, pixel_size: tuple[float, float],
                    spacing: float | None = None) -> tuple[np.ndarray, float]:
    """Resample heights of pixel size (sx, sy) onto a square grid.

    Parameters
    ----------
    heights
        2-D array (nx, ny) at x = i sx, y = j sy; NaN is missing data.
    pixel_size
        (sx, sy) in metres.
    spacing
        Target spacing (m); default min(sx, sy), which keeps the finer
        resolution. The new grid starts at the same origin and stays within
        the scanned rectangle.

    Returns
    -------
    heights, spacing
    """
    sx = require_finite_positive("pixel_size", pixel_size[0])
    sy = require_finite_positive("pixel_size", pixel_size[1])
    s = min(sx, sy) if spacing is None else require_finite_positive("resample", spacing)
    nx, ny = heights.shape
    mx = int(np.floor((nx - 1) * sx / s + SNAP)) + 1
    my = int(np.floor((ny - 1) * sy / s + SNAP)) + 1
    if mx < 1 or my < 1:
        raise InputError("resample", f"spacing {s:g} m is larger than the scan")
    return interpolate_at_indices(heights, np.arange(mx) * (s / sx), np.arange(my) * (s / sy)), s


def snap_to_integers(index):
    """Fractional indices within :data:`SNAP` of an integer, replaced by that integer."""
    nearest = np.round(index)
    return np.where(np.abs(index - nearest) < SNAP, nearest, index)


def _along_axis(values: np.ndarray, index: np.ndarray, axis: int) -> np.ndarray:
    n = values.shape[axis]
    index = snap_to_integers(index)
    inside = (index >= 0) & (index <= n - 1)
    safe = np.where(inside, index, 0.0)
    lower = np.minimum(np.floor(safe).astype(np.intp), n - 1)
    weight = safe - lower
    upper = np.minimum(lower + 1, n - 1)
    a = np.take(values, lower, axis=axis)
    b = np.take(values, upper, axis=axis)
    shape = [1, 1]
    shape[axis] = index.size
    weight = weight.reshape(shape)
    with np.errstate(invalid="ignore"):
        out = np.where(weight == 0.0, a, (1.0 - weight) * a + weight * b)
    return np.where(inside.reshape(shape), out, np.nan)
