"""Self-affine surfaces by Fourier filtering of white noise.

Gaussian white noise on the grid is transformed, multiplied by the square
root of a power-law power spectral density, and transformed back:

.. math::

    C(q) = \\begin{cases}
        C_0 & q < q_r \\\\
        C_0 (q / q_r)^{-2(1+H)} & q_r \\le q \\le q_s \\\\
        0 & q > q_s
    \\end{cases}

with ``q = |q|`` (rad/m), roll-off wavevector ``q_r = 2π/λ_r``, short-
wavelength cut-off ``q_s = 2π/λ_s`` and Hurst exponent ``H = 3 − Δ``
(Persson et al., J. Phys.: Condens. Matter 17, R1, 2005; Jacobs, Junge &
Pastewka, Surf. Topogr.: Metrol. Prop. 5, 013001, 2017). The amplitude
``C_0`` is then fixed by the requested rms height or rms slope. This is the
spectral counterpart of the random midpoint displacement of the paper (§3.3):
the spectrum is an exact power law, and the surface is periodic unless asked
otherwise.

Random numbers: NumPy's PCG64 bit generator (``numpy.random.default_rng(seed)``),
standard normal deviates drawn in one call, in C order, for the whole
generation grid. Every MPI rank (and every machine with the same NumPy
version) that calls with the same arguments obtains the same heights; no
communication is needed.
"""
from __future__ import annotations

import numpy as np

from ..checks import check_seed, check_shape, hurst_exponent, require_finite_positive
from ..errors import InputError
from .statistics import scaled_to_rms
from .topography import Topography

#: Non-periodic surfaces are cut from a periodic one this many times larger
#: along each axis, so that opposite edges are uncorrelated.
NONPERIODIC_PADDING = 2


def fourier_surface(shape, spacing: float = 1.0, *, hurst: float | None = None,
                    fractal_dimension: float | None = None,
                    rms_height: float | None = None, rms_slope: float | None = None,
                    rolloff_wavelength: float | None = None,
                    short_cutoff_wavelength: float | None = None,
                    periodic: bool = True, seed: int = 0) -> Topography:
    """A Gaussian self-affine surface with a power-law spectrum.

    Parameters
    ----------
    shape
        Node counts (nx, ny), or n for a square grid.
    spacing
        Grid spacing s (m).
    hurst, fractal_dimension
        Exactly one: Hurst exponent H in (0, 1) or fractal dimension
        Δ = 3 − H in (2, 3).
    rms_height, rms_slope
        Exactly one: the rms height (m) or rms slope of the result, as defined
        in :mod:`.statistics` (Sq about the mean; Sdq by forward differences).
    rolloff_wavelength
        λ_r (m): the spectrum is flat for wavelengths longer than λ_r. Default:
        no roll-off, the power law extends to the longest wavelength.
    short_cutoff_wavelength
        λ_s (m): no roughness below this wavelength. Default: none (the
        Nyquist wavelength 2s is the natural cut-off). Must be at least 2s.
    periodic
        If True (default) the surface is periodic on the grid, as needed by
        FFT-based contact solvers. If False it is cut from a periodic surface
        ``NONPERIODIC_PADDING`` times larger along each axis.
    seed
        Seed of the PCG64 generator.

    Returns
    -------
    Topography
        Zero-mean heights; metadata records the generator, its parameters,
        the random generator and the NumPy version.
    """
    nx, ny = check_shape(shape, minimum=2)
    s = require_finite_positive("spacing", spacing)
    hurst = hurst_exponent(fractal_dimension, hurst)
    seed = check_seed(seed)
    if rms_height is None and rms_slope is None:
        raise InputError("rms_height", "give rms_height (m) or rms_slope to set the amplitude")
    q_short = np.inf
    if short_cutoff_wavelength is not None:
        lambda_s = require_finite_positive("short_cutoff_wavelength", short_cutoff_wavelength)
        if lambda_s < 2.0 * s * (1.0 - 1e-12):
            raise InputError("short_cutoff_wavelength",
                             f"{lambda_s:g} m is below the Nyquist wavelength 2s = {2 * s:g} m")
        q_short = 2.0 * np.pi / lambda_s
    q_rolloff = 0.0
    if rolloff_wavelength is not None:
        lambda_r = require_finite_positive("rolloff_wavelength", rolloff_wavelength)
        if short_cutoff_wavelength is not None and not lambda_r > lambda_s:
            raise InputError("rolloff_wavelength",
                             f"{lambda_r:g} m must exceed the short cut-off wavelength {lambda_s:g} m")
        q_rolloff = 2.0 * np.pi / lambda_r
    if not isinstance(periodic, (bool, np.bool_)):
        raise InputError("periodic", f"must be True or False, got {periodic!r}")

    pad = 1 if periodic else NONPERIODIC_PADDING
    mx, my = pad * nx, pad * ny
    qx = 2.0 * np.pi * np.fft.fftfreq(mx, d=s)
    qy = 2.0 * np.pi * np.fft.rfftfreq(my, d=s)
    amplitude = _power_law_amplitude(np.hypot(qx[:, None], qy[None, :]), hurst, q_rolloff, q_short,
                                     2.0 * np.pi / (max(mx, my) * s))
    if not amplitude.any():
        raise InputError("short_cutoff_wavelength", "removes every Fourier mode of the grid")
    rng = np.random.default_rng(seed)
    spectrum = np.fft.rfft2(rng.standard_normal((mx, my)))
    spectrum *= amplitude
    del amplitude
    heights = np.fft.irfft2(spectrum, s=(mx, my))
    del spectrum
    if not periodic:
        heights = heights[:nx, :ny].copy()  # release the padded grid
    heights -= heights.mean()
    heights = scaled_to_rms(heights, s, rms_height, rms_slope)
    meta = dict(generator="Fourier filtering", hurst=hurst, fractal_dimension=3.0 - hurst,
                rolloff_wavelength=rolloff_wavelength, short_cutoff_wavelength=short_cutoff_wavelength,
                periodic=bool(periodic), seed=seed, rms_height=rms_height, rms_slope=rms_slope,
                rng="numpy PCG64 (default_rng), standard_normal", numpy=np.__version__)
    return Topography(heights, s, None, meta)


def _power_law_amplitude(q: np.ndarray, hurst: float, q_rolloff: float, q_short: float,
                         q_unit: float) -> np.ndarray:
    """sqrt(C(q)) of the roll-off power law, zero at q = 0 and above q_short (overwrites q)."""
    exponent = -(1.0 + hurst)  # sqrt of q^(-2(1+H))
    reference = max(q_rolloff, q_unit)
    removed = (q == 0) | (q > q_short * (1.0 + 1e-12))
    amplitude = np.maximum(q, q_rolloff, out=q)
    amplitude /= reference
    with np.errstate(divide="ignore"):
        np.power(amplitude, exponent, out=amplitude)
    amplitude[removed] = 0.0
    return amplitude
