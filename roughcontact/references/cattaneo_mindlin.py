"""Cattaneo–Mindlin partial slip of a Hertzian contact under Q < fP (Johnson 1985, §7.2).

Valid for the uncoupled case β = 0 and, in three dimensions, exact when ν = 0
(paper §1.1, §4.1). The tangential approach follows the paper's Eq. 24:
δx = f (δz − δz*), δz* = c²/R the Hertz approach of the stick circle.
"""
from __future__ import annotations

import numpy as np

from . import hertz


def stick_radius(contact_radius: float, tangential: float, friction: float, load: float) -> float:
    """c = a (1 − Q / (f P))^(1/3)."""
    return contact_radius * (1.0 - tangential / (friction * load)) ** (1.0 / 3.0)


def traction(r: np.ndarray, approach: float, radius: float, contact_modulus: float,
             tangential: float, friction: float) -> np.ndarray:
    """q(r) = f p0 [sqrt(1 − r²/a²) − (c/a) sqrt(1 − r²/c²)] (second term only for r < c)."""
    a = hertz.contact_radius(approach, radius)
    p_load = hertz.load(approach, radius, contact_modulus)
    c = stick_radius(a, tangential, friction, p_load)
    p0 = hertz.peak_pressure(approach, radius, contact_modulus)
    r = np.asarray(r, dtype=float)
    outer = np.sqrt(np.clip(1.0 - (r / a) ** 2, 0.0, None))
    inner = (c / a) * np.sqrt(np.clip(1.0 - (r / c) ** 2, 0.0, None)) if c > 0 else 0.0
    return friction * p0 * (outer - inner)


def tangential_approach(approach: float, radius: float, contact_modulus: float,
                        tangential: float, friction: float) -> float:
    """δx = f (a² − c²) / R = (3 f P / (4 E* a)) [1 − (1 − Q/fP)^(2/3)] (Eq. 24)."""
    a = hertz.contact_radius(approach, radius)
    p_load = hertz.load(approach, radius, contact_modulus)
    c = stick_radius(a, tangential, friction, p_load)
    return friction * (a**2 - c**2) / radius
