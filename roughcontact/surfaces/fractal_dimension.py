"""Estimators of the fractal dimension Δ of a surface (paper §3.3–3.4).

A self-affine surface of Hurst exponent H has fractal dimension Δ = 3 − H
(2 < Δ < 3). Three estimators, each a straight-line fit in log–log axes:

- **PSD slope**: ``C(q) ∝ q^(−2(1+H))``, so ``Δ = 4 + slope / 2``
  (Persson et al., J. Phys.: Condens. Matter 17, R1, 2005).
- **Variogram** (structure function): ``S(r) ∝ r^(2H)``, so
  ``Δ = 3 − slope / 2`` (Mandelbrot 1982; the "partitioning" method).
- **Cube counting**: the number N(ε) of cubes of side ε of a lattice that
  the surface crosses, ``N ∝ ε^(−Δ)``, so ``Δ = −slope``. Heights are
  z-expanded so that their range equals the lateral size of the analysed
  square, as in Gwyddion's cube counting (Nečas & Klapetek, Cent. Eur. J.
  Phys. 10, 181, 2012); box sizes are s, 2s, 4s, … . The count is the
  box-counting definition of Δ used for the contact domains in §3.2.

The default fit ranges leave out the largest scales (few samples, and the
finite size) and, for the PSD, the shortest wavelengths (aliasing and the
instrument's transfer function); ``scale_range`` (metres: wavelength, lag or
box size) overrides them. Estimators differ on real data, which is why the
documentation prints all three.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import check_choice, check_scale_range
from ..errors import InputError
from .statistics import radial_psd, structure_function, valid_nodes
from .topography import Topography

METHODS = ("psd", "variogram", "cube_counting")


@dataclass(frozen=True)
class FractalDimensionEstimate:
    """A fractal dimension fitted on a log–log plot.

    Attributes
    ----------
    method
        ``"psd"``, ``"variogram"`` or ``"cube_counting"``.
    fractal_dimension
        Δ.
    hurst
        H = 3 − Δ.
    slope
        Slope of the log–log fit.
    scales
        Length scale of every point (m): wavelength 2π/q, lag r or box size ε.
    values
        C(q) (m⁴), S(r) (m²) or N(ε).
    fitted
        Points that entered the fit.
    """

    method: str
    fractal_dimension: float
    hurst: float
    slope: float
    scales: np.ndarray
    values: np.ndarray
    fitted: np.ndarray


def fractal_dimension(topography: Topography, method: str = "psd",
                      scale_range: tuple[float, float] | None = None) -> FractalDimensionEstimate:
    """Δ of ``topography`` by one of :data:`METHODS`."""
    method = check_choice("method", method, METHODS)
    return {"psd": fractal_dimension_psd, "variogram": fractal_dimension_variogram,
            "cube_counting": fractal_dimension_cube_counting}[method](topography, scale_range=scale_range)


def fractal_dimensions(topography: Topography) -> dict[str, FractalDimensionEstimate]:
    """Δ by every estimator, with default fit ranges."""
    return {method: fractal_dimension(topography, method) for method in METHODS}


def fractal_dimension_psd(topography: Topography, scale_range=None,
                          window: str | None = "hann") -> FractalDimensionEstimate:
    """Δ from the slope of the radially averaged PSD, ``Δ = 4 + slope/2``.

    Default fit: wavelengths from 4s (above the aliased band near the
    Nyquist wavelength 2s) to a quarter of the shorter side.
    """
    scale_range = check_scale_range(scale_range)
    spectrum = radial_psd(topography, window=window)
    wavelength = 2.0 * np.pi / spectrum.wavevector
    if scale_range is None:
        scale_range = (4.0 * topography.spacing, min(topography.shape) * topography.spacing / 4.0)
    slope, fitted = _fit(wavelength, spectrum.psd, scale_range, log_x=np.log(spectrum.wavevector))
    return FractalDimensionEstimate("psd", 4.0 + slope / 2.0, -1.0 - slope / 2.0, slope,
                                    wavelength, spectrum.psd, fitted)


def fractal_dimension_variogram(topography: Topography, scale_range=None) -> FractalDimensionEstimate:
    """Δ from the slope of the structure function, ``Δ = 3 − slope/2``.

    Default fit: lags from 2s (at one spacing the discrete surface is still
    smoother than its power law) to a tenth of the shorter side.
    """
    scale_range = check_scale_range(scale_range)
    variogram = structure_function(topography)
    if scale_range is None:
        scale_range = (2.0 * topography.spacing, min(topography.shape) * topography.spacing / 10.0)
    slope, fitted = _fit(variogram.distance, variogram.structure_function, scale_range)
    return FractalDimensionEstimate("variogram", 3.0 - slope / 2.0, slope / 2.0, slope,
                                    variogram.distance, variogram.structure_function, fitted)


def fractal_dimension_cube_counting(topography: Topography, scale_range=None) -> FractalDimensionEstimate:
    """Δ by cube counting on z-expanded heights, ``Δ = −slope``.

    The largest square of the grid is analysed; a column of ``k + 1`` by
    ``k + 1`` nodes (box size ε = k s, k = 1, 2, 4, …) counts the lattice
    cubes of side ε between its lowest and highest node,
    ``floor(max/ε) − floor(min/ε) + 1``; only columns wholly inside the
    footprint count, and N(ε) is scaled to the full square. Default fit:
    box sizes from 4s to an eighth of the side.

    Cube counting underestimates Δ of rough surfaces: the height range of
    the few nodes of a small column grows with their number faster than
    ε^H, which flattens the log–log plot. On generated surfaces of 513²
    nodes it returns about 2.16, 2.35 and 2.52 for Δ = 2.2, 2.5 and 2.8
    (``tests/test_surfaces_fractal_dimension.py``, ``docs/surfaces.md``);
    prefer the PSD or variogram estimators above Δ ≈ 2.3.
    """
    scale_range = check_scale_range(scale_range)
    mask = valid_nodes(topography)
    side = min(topography.shape)
    if side < 5:
        raise InputError("topography", f"cube counting needs at least 5 nodes a side, got {topography.shape}")
    s = topography.spacing
    heights = topography.heights[:side, :side]
    mask = mask[:side, :side]
    lateral = (side - 1) * s
    lowest, highest = heights[mask].min(), heights[mask].max()
    if not highest > lowest:
        raise InputError("topography", "is flat: cube counting needs a height range")
    z = np.where(mask, (heights - lowest) * (lateral / (highest - lowest)), 0.0)
    sizes, counts = [], []
    k = 1
    while (side - 1) // k >= 2:
        cells = (side - 1) // k
        top = _column_extreme(z, k, cells, np.maximum)
        bottom = _column_extreme(z, k, cells, np.minimum)
        inside = _column_extreme(mask.astype(np.int8), k, cells, np.minimum).astype(bool)
        if inside.any():
            eps = k * s
            cubes = np.floor(top[inside] / eps) - np.floor(bottom[inside] / eps) + 1.0
            sizes.append(eps)
            counts.append(cubes.mean() * (lateral / eps) ** 2)
        k *= 2
    sizes, counts = np.asarray(sizes), np.asarray(counts)
    if scale_range is None:
        scale_range = (4.0 * s, lateral / 8.0)
    slope, fitted = _fit(sizes, counts, scale_range)
    return FractalDimensionEstimate("cube_counting", -slope, 3.0 + slope, slope, sizes, counts, fitted)


def _column_extreme(values: np.ndarray, k: int, cells: int, ufunc) -> np.ndarray:
    """ufunc-reduction over the (k+1)² nodes of each column of ``cells`` × ``cells``."""
    n = cells * k
    out = values[: n + 1, : n + 1]
    for axis in (0, 1):
        body = np.take(out, np.arange(n), axis=axis)
        shape = list(body.shape)
        shape[axis: axis + 1] = [cells, k]
        blocks = ufunc.reduce(body.reshape(shape), axis=axis + 1)
        closing = np.take(out, np.arange(k, n + 1, k), axis=axis)
        out = ufunc(blocks, closing)
    return out


def _fit(scales: np.ndarray, values: np.ndarray, scale_range: tuple[float, float],
         log_x: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """Least-squares slope of log(values) against log(x) over ``scale_range``."""
    lo, hi = scale_range
    fitted = (scales >= lo * (1 - 1e-9)) & (scales <= hi * (1 + 1e-9)) & (values > 0) & np.isfinite(values)
    if fitted.sum() < 3:
        raise InputError("scale_range", f"({lo:g}, {hi:g}) m holds {int(fitted.sum())} point(s) of the "
                         "log–log plot; at least 3 are needed for a slope")
    x = np.log(scales) if log_x is None else log_x
    slope = np.polyfit(x[fitted], np.log(values[fitted]), 1)[0]
    return float(slope), fitted
