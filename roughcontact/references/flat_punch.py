"""Rigid flat circular punch of radius a on an elastic half-space (Johnson 1985, §3.8)."""
from __future__ import annotations

import numpy as np


def stiffness(radius: float, contact_modulus: float) -> float:
    """P / δ = 2 a E*."""
    return 2.0 * radius * contact_modulus


def pressure(r: np.ndarray, load: float, radius: float) -> np.ndarray:
    """p(r) = P / (2 π a sqrt(a² − r²)) under the punch."""
    r = np.asarray(r, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r < radius, load / (2.0 * np.pi * radius * np.sqrt(radius**2 - r**2)), 0.0)
