"""Checks of the tangential inputs: f, Q, its direction, step counts, amplitudes, the normal state.

Each returns the cleaned value or raises :class:`~roughcontact.errors.InputError`
naming the parameter as the user wrote it; Q at or beyond fP is the
full-sliding error (§5.2: displacements undetermined there).
"""
from __future__ import annotations

import math

import numpy as np

from ..checks import require_finite
from ..errors import InputError
from ..normal.problem import NormalProblem
from ..normal.result import NormalResult


def check_friction(friction) -> float:
    """f as a float, or :class:`InputError` unless finite and > 0."""
    f = require_finite("friction", friction)
    if f <= 0.0:
        raise InputError("friction", f"the Coulomb coefficient f must be finite and > 0, got {friction!r}")
    return f


def check_steps(steps) -> int:
    """N as an int, or :class:`InputError` unless an integer >= 1."""
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise InputError("steps", f"must be an integer >= 1, got {steps!r}")
    return int(steps)


def check_direction(direction) -> tuple[float, float]:
    """The unit vector along ``direction`` (any non-zero in-plane vector)."""
    try:
        ex, ey = (float(v) for v in direction)
    except (TypeError, ValueError):
        raise InputError("direction", f"must be an in-plane vector (x, y), got {direction!r}") from None
    norm = math.hypot(ex, ey)
    if not math.isfinite(norm):
        raise InputError("direction", f"must be finite, got {direction!r}")
    if norm == 0.0:
        raise InputError("direction", "is the zero vector: the tangential load Q needs a direction")
    return ex / norm, ey / norm


def check_tangential(tangential, friction: float, load: float, name: str = "tangential") -> float:
    """Q as a float in [0, fP), or :class:`InputError` saying why not (Q ≥ fP: full sliding)."""
    q = require_finite(name, tangential)
    if q < 0.0:
        raise InputError(name, f"must be >= 0, got {q!r}; reverse `direction` for a load the other way")
    if q >= friction * load:
        raise full_sliding(name, q, friction * load)
    return q


def full_sliding(name: str, q: float, limit: float, within: float | None = None) -> InputError:
    """The error for Q at or beyond fP (``within``: the load tolerance by which Q is below fP)."""
    detail = f" to within the normal solve's load tolerance ({within:g})" if within is not None else ""
    return InputError(name, f"Q = {q:.6g} N >= fP = {limit:.6g} N{detail}: full sliding. The traction is then "
                            "f p everywhere but the tangential displacements are undetermined (§5.2); use "
                            "CattaneoSolver.incipient_sliding() for the limit Q -> fP (Eq. 27)")


def check_normal(problem: NormalProblem, normal) -> None:
    """:class:`InputError` unless ``normal`` solved ``problem`` with a load P > 0."""
    if not isinstance(normal, NormalResult):
        raise InputError("normal", f"must be a NormalResult, got {type(normal).__name__}")
    normal.require_whole("normal")
    problem.require_whole_topography("a tangential solve")
    if normal.force.shape != problem.topography.shape:
        raise InputError("normal", f"its fields have shape {normal.force.shape}, the problem's grid "
                                   f"{problem.topography.shape}: it was solved on another problem")
    if not np.allclose(normal.reference_point, problem.centroid, rtol=0.0,
                       atol=1e-9 * problem.topography.spacing):
        raise InputError("normal", "its moments refer to another footprint centroid: "
                                   "it was solved on another problem")
    if not normal.load > 0.0:
        raise InputError("normal", f"the normal load P must be > 0 for a tangential load "
                                   f"(fP is the limit of Q), got P = {normal.load!r}")


def check_amplitudes(amplitudes, name: str = "amplitudes") -> np.ndarray:
    """Q*/(fP) values: a non-empty, strictly increasing list in (0, 1)."""
    values = np.atleast_1d(np.asarray(amplitudes, dtype=float))
    if values.ndim != 1 or values.size == 0:
        raise InputError(name, "must be a non-empty list of Q*/(fP)")
    if not np.all(np.isfinite(values)) or values.min() <= 0.0 or values.max() >= 1.0:
        raise InputError(name, f"are Q*/(fP) and must lie in (0, 1), got {values.tolist()!r}")
    if np.any(np.diff(values) <= 0.0):
        raise InputError(name, f"must be strictly increasing (the amplitude is stepped up), got {values.tolist()!r}")
    return values
