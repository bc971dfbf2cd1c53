"""Height statistics of a topography: rms height, rms slope, PSD, structure function.

Every statistic is taken over the footprint only (the nodes of the nominal
contact region, §3.1), so a disc-shaped core section or a scan with masked
missing points gives the statistics of the measured surface, not of padding.

Conventions
-----------
- rms height ``Sq = sqrt(<(h − <h>)²>)`` about the footprint mean (ISO 25178
  Sq after mean levelling).
- rms slope ``Sdq = sqrt(<(∂h/∂x)²> + <(∂h/∂y)²>)`` with forward differences
  between neighbouring footprint nodes, ``∂h/∂x ≈ (h[i+1, j] − h[i, j]) / s``;
  exact for a plane.
- 2-D power spectral density ``C(q)`` normalised so that
  ``<h²> = Σ_q C(q) Δq_x Δq_y`` (Parseval), with ``q = |q|`` in rad/m and
  ``Δq = 2π / L``; a self-affine surface of Hurst exponent H has
  ``C(q) ∝ q^(−2(1+H))`` (Persson, J. Phys.: Condens. Matter 17, R1, 2005).
- structure function (variogram) ``S(r) = <(h(x + r) − h(x))²>`` along the
  grid axes; a self-affine surface has ``S(r) ∝ r^(2H)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import check_choice, check_integer, require_finite_positive
from ..errors import InputError
from .topography import Topography


@dataclass(frozen=True)
class RadialPSD:
    """Radially averaged 2-D power spectral density.

    Attributes
    ----------
    wavevector
        Geometric mean of ``|q|`` in each bin (rad/m).
    psd
        Mean of ``C(q)`` over the Fourier modes of the bin (m⁴).
    counts
        Number of Fourier modes in each bin.
    wavevector_spacing
        (Δq_x, Δq_y) = (2π/L_x, 2π/L_y) (rad/m); ``Σ counts · psd · Δq_x Δq_y``
        equals the mean-square height seen by the transform.
    """

    wavevector: np.ndarray
    psd: np.ndarray
    counts: np.ndarray
    wavevector_spacing: tuple[float, float]


@dataclass(frozen=True)
class StructureFunction:
    """Structure function (variogram) along the grid axes.

    Attributes
    ----------
    distance
        Lag r (m).
    structure_function
        ``S(r) = <(h(x + r) − h(x))²>`` (m²), pooled over the x and y axes.
    pairs
        Number of node pairs behind each value.
    """

    distance: np.ndarray
    structure_function: np.ndarray
    pairs: np.ndarray


def valid_nodes(topography: Topography) -> np.ndarray:
    """Nodes in the footprint with a finite height (boolean mask)."""
    return topography.footprint & np.isfinite(topography.heights)


def rms_height(topography: Topography) -> float:
    """Root-mean-square height Sq about the footprint mean (m)."""
    return _rms_height(topography.heights, valid_nodes(topography))


def rms_slope(topography: Topography) -> float:
    """Root-mean-square slope Sdq from forward differences on the footprint.

    Only pairs of neighbouring nodes that both belong to the footprint enter.
    Exact for a plane ``h = a x + b y + c`` (gives ``sqrt(a² + b²)``).
    """
    return _rms_slope(topography.heights, topography.spacing, valid_nodes(topography))


def radial_psd(topography: Topography, window: str | None = "hann",
               bins_per_decade: int = 20) -> RadialPSD:
    """Radially averaged power spectral density C(q) of the footprint.

    Parameters
    ----------
    topography
        Heights; nodes outside the footprint count as zero after the
        footprint mean is removed (the PSD of a masked scan is then an
        estimate, normalised by the number of footprint nodes).
    window
        ``"hann"`` (default: a measured or non-periodic surface, whose edges
        would otherwise leak power as a ``q^-3`` tail) or ``None`` (periodic
        surfaces; then Parseval holds exactly). The window is normalised to
        unit mean square over the footprint, so the rms height is kept.
    bins_per_decade
        Logarithmic bins of ``|q|`` per decade.

    Returns
    -------
    RadialPSD
    """
    window = check_choice("window", window, ("hann", None))
    bins_per_decade = check_integer("bins_per_decade", bins_per_decade, 1)
    mask = valid_nodes(topography)
    heights = np.where(mask, topography.heights, 0.0)
    heights = np.where(mask, heights - heights[mask].mean(), 0.0)
    nx, ny = heights.shape
    if window == "hann":
        taper = np.outer(np.hanning(nx) if nx > 2 else np.ones(nx), np.hanning(ny) if ny > 2 else np.ones(ny))
    else:
        taper = np.ones((nx, ny))
    weight = float(np.sum(taper**2 * mask))
    s = topography.spacing
    spectrum = np.fft.fft2(heights * taper)
    psd = np.abs(spectrum) ** 2 * s**2 / (4.0 * np.pi**2 * weight)
    qx = 2.0 * np.pi * np.fft.fftfreq(nx, d=s)
    qy = 2.0 * np.pi * np.fft.fftfreq(ny, d=s)
    q = np.hypot(qx[:, None], qy[None, :])
    dq = (2.0 * np.pi / (nx * s), 2.0 * np.pi / (ny * s))
    keep = q > 0
    q, psd = q[keep], psd[keep]
    if q.size == 0:
        raise InputError("topography", "a single node has no spectrum")
    edges = np.logspace(np.log10(q.min()), np.log10(q.max()),
                        max(2, int(np.ceil(np.log10(q.max() / q.min()) * bins_per_decade)) + 1))
    edges[0] *= 1.0 - 1e-9
    edges[-1] *= 1.0 + 1e-9
    which = np.digitize(q, edges) - 1
    counts = np.bincount(which, minlength=edges.size - 1)
    sums = np.bincount(which, weights=psd, minlength=edges.size - 1)
    logq = np.bincount(which, weights=np.log(q), minlength=edges.size - 1)
    filled = counts > 0
    return RadialPSD(np.exp(logq[filled] / counts[filled]), sums[filled] / counts[filled],
                     counts[filled], dq)


def structure_function(topography: Topography, lags=None) -> StructureFunction:
    """Structure function S(r) pooled over the x and y grid axes.

    Parameters
    ----------
    topography
        Heights; only pairs of footprint nodes enter.
    lags
        Integer lags in nodes; default about 10 per decade from 1 to half the
        larger side.
    """
    mask = valid_nodes(topography)
    heights = np.where(mask, topography.heights, 0.0)
    longest = max(heights.shape) - 1
    if longest < 1:
        raise InputError("topography", "a single node has no structure function")
    if lags is None:
        top = max(1, longest // 2)
        lags = np.unique(np.round(np.logspace(0, np.log10(top), max(2, int(10 * np.log10(top)) + 1))).astype(int))
    else:
        lags = np.unique(np.asarray([check_integer("lags", k, 1, longest) for k in np.ravel(lags)], dtype=int))
    values = np.zeros(lags.size)
    pairs = np.zeros(lags.size, dtype=np.int64)
    for n, k in enumerate(lags):
        total = 0.0
        count = 0
        for axis in (0, 1):
            if heights.shape[axis] <= k:
                continue
            diff, both = _increments(heights, mask, axis, k)
            total += float(np.sum(diff[both] ** 2))
            count += int(both.sum())
        pairs[n] = count
        values[n] = total / count if count else np.nan
    filled = pairs > 0
    return StructureFunction(lags[filled] * topography.spacing, values[filled], pairs[filled])


def _increments(heights: np.ndarray, mask: np.ndarray, axis: int, lag: int):
    """h(x + lag e_axis) − h(x), and where both nodes are in ``mask``."""
    ahead = [slice(None)] * 2
    behind = [slice(None)] * 2
    ahead[axis] = slice(lag, None)
    behind[axis] = slice(None, -lag)
    ahead, behind = tuple(ahead), tuple(behind)
    return heights[ahead] - heights[behind], mask[ahead] & mask[behind]


def _rms_height(heights: np.ndarray, mask: np.ndarray) -> float:
    values = heights[mask]
    return float(np.sqrt(np.mean((values - values.mean()) ** 2)))


def _rms_slope(heights: np.ndarray, spacing: float, mask: np.ndarray) -> float:
    mean_square = 0.0
    for axis in (0, 1):
        if heights.shape[axis] < 2:
            continue
        diff, both = _increments(heights, mask, axis, 1)
        if both.any():
            mean_square += float(np.mean((diff[both] / spacing) ** 2))
    if heights.shape[0] < 2 and heights.shape[1] < 2:
        raise InputError("heights", "a single node has no slope")
    return float(np.sqrt(mean_square))


def scaled_to_rms(heights: np.ndarray, spacing: float, rms_height: float | None = None,
                  rms_slope: float | None = None) -> np.ndarray:
    """Heights multiplied so that their rms height or rms slope takes a value.

    Used by the generators: exactly one of ``rms_height`` or ``rms_slope``
    (m, dimensionless) is given; the result satisfies the chosen statistic as
    defined in this module, to rounding. ``heights`` is scaled in place (the
    generators own it) and returned.
    """
    if rms_height is not None and rms_slope is not None:
        raise InputError("rms_slope", "give rms_height or rms_slope, not both")
    mask = np.ones(heights.shape, dtype=bool)
    if rms_height is not None:
        target = require_finite_positive("rms_height", rms_height)
        current = _rms_height(heights, mask)
    elif rms_slope is not None:
        target = require_finite_positive("rms_slope", rms_slope)
        current = _rms_slope(heights, spacing, mask)
    else:
        raise InputError("rms_height", "give rms_height (m) or rms_slope to set the amplitude")
    if not current > 0:
        raise InputError("heights", "are flat: cannot scale a zero rms to a target value")
    heights *= target / current
    return heights
