"""Argument checks shared by every package: numbers, integers, shapes, choices, vectors, seeds.

Each check returns the cleaned value or raises :class:`~roughcontact.errors.InputError`
naming the parameter as the user wrote it, so bad input is a one-line error
and never a traceback from deep inside a solver. The tangential package's own
inputs (f, Q, amplitudes) are checked in :mod:`roughcontact.tangential.checks`.
"""
from __future__ import annotations

import numbers

import numpy as np

from .errors import InputError


def require_finite(name: str, value) -> float:
    """Return ``float(value)`` or raise :class:`InputError` if not a finite number."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(name, f"must be a number, got {value!r}") from None
    if v != v or v in (float("inf"), float("-inf")):
        raise InputError(name, f"must be finite, got {value!r}")
    return v


def require_finite_positive(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`InputError` if not finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(name, f"must be a number, got {value!r}") from None
    if not (v > 0.0) or v == float("inf"):
        raise InputError(name, f"must be finite and > 0, got {value!r}")
    return v


def _number(name: str, value) -> float:
    """``value`` as a float; booleans (Python's and numpy's: ``True`` is not a number here) and
    what float() refuses raise :class:`InputError`."""
    if isinstance(value, (bool, np.bool_)):
        raise InputError(name, f"must be a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(name, f"must be a number, got {value!r}") from None


def check_open_interval(name: str, value, low: float, high: float, meaning: str = "") -> float:
    """``value`` as a float in the open interval (low, high); ``meaning`` follows the interval in
    the error (booleans are refused)."""
    number = _number(name, value)
    if not (low < number < high):
        raise InputError(name, f"must lie in ({low:g}, {high:g}){meaning}, got {value!r}")
    return number


def check_closed_interval(name: str, value, low: float, high: float, meaning: str = "") -> float:
    """``value`` as a float in the closed interval [low, high] (NaN refused); ``meaning`` follows
    the interval in the error (booleans are refused)."""
    number = _number(name, value)
    if not (low <= number <= high):
        raise InputError(name, f"must lie in [{low:g}, {high:g}]{meaning}, got {value!r}")
    return number


def check_fractal_dimension(fractal_dimension: float) -> float:
    """Return Δ as a float, or raise unless 2 < Δ < 3 (a surface)."""
    return check_open_interval("fractal_dimension", fractal_dimension, 2.0, 3.0, " for a surface")


def hurst_exponent(fractal_dimension: float | None = None, hurst: float | None = None) -> float:
    """The Hurst exponent H = 3 − Δ from exactly one of Δ or H (0 < H < 1)."""
    if (fractal_dimension is None) == (hurst is None):
        raise InputError("hurst", "give exactly one of fractal_dimension (Δ in (2, 3)) or hurst (H = 3 − Δ in (0, 1))")
    if fractal_dimension is not None:
        return 3.0 - check_fractal_dimension(fractal_dimension)
    return check_open_interval("hurst", hurst, 0.0, 1.0, " (Δ = 3 − H in (2, 3))")


def check_seed(seed) -> int:
    """A non-negative integer seed of the PCG64 generator."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral):
        raise InputError("seed", f"must be a non-negative integer (the surface is reproducible from it), got {seed!r}")
    if seed < 0:
        raise InputError("seed", f"must be >= 0, got {seed!r}")
    return int(seed)


def check_integer(name: str, value, minimum: int, maximum: int | None = None) -> int:
    """An integer in [minimum, maximum]; floats equal to an integer are accepted."""
    if isinstance(value, bool):
        raise InputError(name, f"must be an integer, got {value!r}")
    try:
        as_int = int(value)
        ok = as_int == value
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise InputError(name, f"must be an integer, got {value!r}")
    if as_int < minimum or (maximum is not None and as_int > maximum):
        upper = "" if maximum is None else f" and <= {maximum}"
        raise InputError(name, f"must be >= {minimum}{upper}, got {value!r}")
    return as_int


def check_shape(shape, name: str = "shape", minimum: int = 1) -> tuple[int, int]:
    """A pair of node counts (nx, ny); a single integer n means (n, n)."""
    if np.ndim(shape) == 0:
        shape = (shape, shape)
    try:
        nx, ny = shape
    except (TypeError, ValueError):
        raise InputError(name, f"must be a node count or a pair of node counts, got {shape!r}") from None
    return check_integer(name, nx, minimum), check_integer(name, ny, minimum)


def check_choice(name: str, value, choices):
    """``value`` if it is one of ``choices``."""
    if value not in choices:
        raise InputError(name, f"must be one of {', '.join(repr(c) for c in choices)}; got {value!r}")
    return value


def check_vector(name: str, value) -> tuple[float, float]:
    """A finite 2-vector (m)."""
    try:
        vx, vy = (float(v) for v in value)
    except (TypeError, ValueError):
        raise InputError(name, f"must be a pair of numbers (x, y) in metres, got {value!r}") from None
    if not (np.isfinite(vx) and np.isfinite(vy)):
        raise InputError(name, f"must be finite, got {value!r}")
    return vx, vy


def check_scale_range(scale_range) -> tuple[float, float] | None:
    """An optional (smallest, largest) length scale of a fit, in metres."""
    if scale_range is None:
        return None
    try:
        lo, hi = scale_range
    except (TypeError, ValueError):
        raise InputError("scale_range", f"must be a pair (smallest, largest) in metres, got {scale_range!r}") from None
    lo = require_finite_positive("scale_range", lo)
    hi = require_finite_positive("scale_range", hi)
    if not lo < hi:
        raise InputError("scale_range", f"smallest scale {lo:g} m must be below largest {hi:g} m")
    return lo, hi
