"""Random midpoint displacement (diamond–square) fractal surfaces (paper §3.3).

The surface is a fractional Brownian surface of Hurst exponent H = 3 − Δ,
generated on a (2**levels + 1)² grid by Saupe's MidPointFM2D algorithm
(Peitgen & Saupe, *The Science of Fractal Images*, 1988, §2.3.3): each level
first displaces the centres of the squares (diamond step), then the midpoints
of their edges (square step); the displacement standard deviation shrinks by
2**(−H/2) at each half-step. With ``random_additions`` the nodes that existed
before a half-step also receive a random addition of the same standard
deviation (successive random additions, same reference), which removes the
creases of plain midpoint displacement.

Midpoint displacement is an approximation of fractional Brownian motion: the
increments of the finest levels scale with a local Hurst exponent somewhat
below H (about 0.55 instead of 0.7 at one spacing, approaching H over tens of
spacings), so estimators fitted on the smallest scales return Δ a few
hundredths high; the Fourier-filtered surfaces of :mod:`.fourier` have an
exact power-law spectrum.

Random numbers come from NumPy's PCG64 generator (``numpy.random.default_rng
(seed)``) drawn in a fixed order that does not depend on the number of
levels, so a seed gives the same surface on any number of MPI ranks and on
any machine with the same NumPy version (recorded in the metadata), and the
first levels of a fine surface are the coarser surface of the same seed.
"""
from __future__ import annotations

import numpy as np

from ..checks import check_fractal_dimension, check_integer, check_seed, require_finite_positive
from ..errors import InputError
from .statistics import scaled_to_rms
from .topography import Topography

__all__ = ["check_fractal_dimension", "midpoint_heights", "midpoint_surface"]


def midpoint_heights(levels: int, fractal_dimension: float, seed: int = 0,
                     random_additions: bool = False) -> np.ndarray:
    """Heights on (2**levels + 1)² nodes, zero mean, unit corner standard deviation.

    Parameters
    ----------
    levels
        Number of refinements, 1 to 14; the grid has 2**levels + 1 nodes a side.
    fractal_dimension
        Δ in (2, 3); the displacement standard deviation shrinks by
        2**(−H/2) at each half-step, H = 3 − Δ.
    seed
        Seed of the PCG64 generator (non-negative integer).
    random_additions
        Successive random additions (Saupe's ``addition`` flag).

    Returns
    -------
    numpy.ndarray
        Dimensionless heights; the four initial corners have unit variance.
    """
    levels = check_integer("levels", levels, 1, 14)
    hurst = 3.0 - check_fractal_dimension(fractal_dimension)
    rng = np.random.default_rng(check_seed(seed))
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
            # Saupe adds to the nodes that existed before this square step (the old
            # corners and the centres), not to the edge midpoints just displaced
            z[0::step, 0::step] += delta * rng.standard_normal(z[0::step, 0::step].shape)
            z[half::step, half::step] += delta * rng.standard_normal(z[half::step, half::step].shape)
        step = half
    z -= z.mean()
    return z


def midpoint_surface(levels: int, fractal_dimension: float, spacing: float = 1.0,
                     rms_height: float | None = None, seed: int = 0,
                     random_additions: bool = False, rms_slope: float | None = None) -> Topography:
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
        If given, heights are scaled to this rms height Sq (m).
    seed
        Seed of the PCG64 generator (non-negative integer).
    random_additions
        Use successive random additions.
    rms_slope
        If given (instead of ``rms_height``), heights are scaled to this rms
        slope Sdq. With neither, the dimensionless heights of
        :func:`midpoint_heights` are multiplied by ``spacing``.

    Returns
    -------
    Topography
        Zero-mean heights on the full rectangle; metadata records the
        generator, its parameters, the random generator and the NumPy version.
    """
    s = require_finite_positive("spacing", spacing)
    if not isinstance(random_additions, (bool, np.bool_)):
        raise InputError("random_additions", f"must be True or False, got {random_additions!r}")
    z = midpoint_heights(levels, fractal_dimension, seed, random_additions)
    if rms_height is None and rms_slope is None:
        z *= s
    else:
        z = scaled_to_rms(z, s, rms_height, rms_slope)
    meta = dict(generator="random midpoint displacement", fractal_dimension=float(fractal_dimension),
                hurst=3.0 - float(fractal_dimension), seed=int(seed), levels=int(levels),
                random_additions=bool(random_additions), rms_height=rms_height, rms_slope=rms_slope,
                rng="numpy PCG64 (default_rng), standard_normal", numpy=np.__version__)
    return Topography(z, s, None, meta)
