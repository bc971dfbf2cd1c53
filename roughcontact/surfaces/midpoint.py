"""Random midpoint displacement (diamond–square) fractal surfaces (paper §3.3).

The surface is a fractional Brownian surface of Hurst exponent H = 3 − Δ,
generated on a (2**levels + 1)² grid by Saupe's MidPointFM2D algorithm
(Peitgen & Saupe, *The Science of Fractal Images*, 1988, §2.3.3): each level
first displaces the centres of the squares (diamond step), then the midpoints
of their edges (square step); the displacement standard deviation shrinks by
2**(−H/2) at each half-step. With ``random_additions`` every existing node
also receives a new random addition at each half-step (successive random
additions, same reference), which removes the creases of plain midpoint
displacement.

Random numbers come from NumPy's PCG64 generator (``numpy.random.default_rng
(seed)``) drawn in a fixed order, so a seed gives the same surface on any
number of MPI ranks and any machine.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, require_finite_positive
from .topography import Topography


def check_fractal_dimension(fractal_dimension: float) -> float:
    """Return Δ as a float, or raise unless 2 < Δ < 3."""
    try:
        d = float(fractal_dimension)
    except (TypeError, ValueError):
        raise InputError("fractal_dimension", f"must be a number, got {fractal_dimension!r}") from None
    if not (2.0 < d < 3.0):
        raise InputError("fractal_dimension", f"must lie in (2, 3) for a surface, got {fractal_dimension!r}")
    return d


def midpoint_heights(levels: int, fractal_dimension: float, seed: int = 0,
                     random_additions: bool = False) -> np.ndarray:
    """Heights (2**levels + 1)² of unit initial standard deviation, zero mean."""
    if int(levels) != levels or not (1 <= int(levels) <= 14):
        raise InputError("levels", f"must be an integer from 1 to 14 (grid 2**levels + 1), got {levels!r}")
    levels = int(levels)
    hurst = 3.0 - check_fractal_dimension(fractal_dimension)
    rng = np.random.default_rng(seed)
    n = 2**levels + 1
    z = np.zeros((n, n))
    delta = 1.0
    z[:: n - 1, :: n - 1] = delta * rng.standard_normal((2, 2))
    step = n - 1
    shrink = 0.5 ** (0.5 * hurst)
    while step > 1:
        half = step // 2
        # diamond step: centres of squares from their four corners
        delta *= shrink
        corners = (z[0:-1:step, 0:-1:step] + z[step::step, 0:-1:step]
                   + z[0:-1:step, step::step] + z[step::step, step::step]) / 4.0
        z[half::step, half::step] = corners + delta * rng.standard_normal(corners.shape)
        if random_additions:
            z[0::step, 0::step] += delta * rng.standard_normal(z[0::step, 0::step].shape)
        # square step: edge midpoints from their (up to) four neighbours
        delta *= shrink
        for ox, oy in ((half, 0), (0, half)):
            sub = z[ox::step, oy::step]
            total = np.zeros(sub.shape)
            count = np.zeros(sub.shape)
            ix = np.arange(ox, n, step)[:, None]
            iy = np.arange(oy, n, step)[None, :]
            for dx, dy in ((-half, 0), (half, 0), (0, -half), (0, half)):
                jx, jy = ix + dx, iy + dy
                ok = (jx >= 0) & (jx < n) & (jy >= 0) & (jy < n)
                total += np.where(ok, z[np.clip(jx, 0, n - 1), np.clip(jy, 0, n - 1)], 0.0)
                count += ok
            z[ox::step, oy::step] = total / count + delta * rng.standard_normal(sub.shape)
        if random_additions:
            z[0::half, 0::half] += delta * rng.standard_normal(z[0::half, 0::half].shape)
        step = half
    return z - z.mean()


def midpoint_surface(levels: int, fractal_dimension: float, spacing: float = 1.0,
                     rms_height: float | None = None, seed: int = 0,
                     random_additions: bool = False) -> Topography:
    """A random-midpoint-displacement surface as a :class:`Topography`.

    Parameters
    ----------
    levels
        Grid of (2**levels + 1)² nodes.
    fractal_dimension
        Δ in (2, 3); Hurst exponent H = 3 − Δ.
    spacing
        Grid spacing s (m).
    rms_height
        If given, heights are scaled to this rms (m); otherwise the initial
        corner standard deviation is ``spacing * 2**levels``'s order, i.e.
        the unit-σ heights are multiplied by ``spacing``.
    seed
        Seed of the PCG64 generator.
    random_additions
        Use successive random additions.
    """
    s = require_finite_positive("spacing", spacing)
    z = midpoint_heights(levels, fractal_dimension, seed, random_additions)
    if rms_height is None:
        z = z * s
    else:
        z = z * (require_finite_positive("rms_height", rms_height) / np.sqrt(np.mean(z**2)))
    meta = dict(generator="random midpoint displacement", fractal_dimension=float(fractal_dimension),
                hurst=3.0 - float(fractal_dimension), seed=int(seed), levels=int(levels),
                random_additions=bool(random_additions), rng="numpy PCG64")
    return Topography(z, s, None, meta)
