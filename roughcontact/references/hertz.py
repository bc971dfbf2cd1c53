"""Hertz: an elastic sphere of radius R pressed on a flat (Johnson 1985, §4.2).

E* is the composite modulus 2/A (paper Eq. 4a, footnote 2).
"""
from __future__ import annotations

import numpy as np


def contact_radius(approach: float, radius: float) -> float:
    """a = sqrt(R δ)."""
    return float(np.sqrt(radius * approach))


def load(approach: float, radius: float, contact_modulus: float) -> float:
    """P = (4/3) E* R^(1/2) δ^(3/2)."""
    return 4.0 / 3.0 * contact_modulus * np.sqrt(radius) * approach**1.5


def approach_for_load(load_: float, radius: float, contact_modulus: float) -> float:
    """δ such that :func:`load` returns ``load_``."""
    return (3.0 * load_ / (4.0 * contact_modulus * np.sqrt(radius))) ** (2.0 / 3.0)


def peak_pressure(approach: float, radius: float, contact_modulus: float) -> float:
    """p0 = 2 E* a / (π R)."""
    return 2.0 * contact_modulus * contact_radius(approach, radius) / (np.pi * radius)


def pressure(r: np.ndarray, approach: float, radius: float, contact_modulus: float) -> np.ndarray:
    """p(r) = p0 sqrt(1 − r²/a²) inside the contact, 0 outside."""
    a = contact_radius(approach, radius)
    p0 = peak_pressure(approach, radius, contact_modulus)
    return p0 * np.sqrt(np.clip(1.0 - (np.asarray(r) / a) ** 2, 0.0, None))
