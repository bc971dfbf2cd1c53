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


# ---------------------------------------------------------------------------
# Shear carried by the zones, energies and the fretting loop (Mindlin &
# Deresiewicz 1953; Johnson 1985, §7.3). With t = Q/(fP), c/a = (1 − t)^(1/3)
# and the scale δ0 = f a²/R of the tangential approach,
# δx(Q) = δ0 [1 − (1 − t)^(2/3)] (Eq. 24).

def _ratio(approach: float, radius: float, contact_modulus: float, tangential: float,
           friction: float) -> tuple[float, float, float]:
    """(t = Q/fP, P, δ0 = f a²/R) of the Hertz contact at ``approach``."""
    p_load = hertz.load(approach, radius, contact_modulus)
    return tangential / (friction * p_load), p_load, friction * approach


def slip_force(approach: float, radius: float, contact_modulus: float, tangential: float,
               friction: float) -> float:
    """Q_slip = f × (Hertz load on c < r < a) = f P (1 − c²/a²)^(3/2)."""
    t, p_load, _ = _ratio(approach, radius, contact_modulus, tangential, friction)
    return friction * p_load * (1.0 - (1.0 - t) ** (2.0 / 3.0)) ** 1.5


def frictional_energy(approach: float, radius: float, contact_modulus: float, tangential: float,
                      friction: float) -> float:
    """E_f = Q δx − 2 ∫₀^Q δx dQ' = f P δ0 [6/5 (1 − (1 − t)^(5/3)) − t − t (1 − t)^(2/3)].

    The energy dissipated under monotonic loading to Q (paper Eq. 26 summed):
    the work Q δx − ∫ δx dQ less the stored energy ½ (Q δx − E_f).
    """
    t, p_load, delta0 = _ratio(approach, radius, contact_modulus, tangential, friction)
    return friction * p_load * delta0 * (1.2 * (1.0 - (1.0 - t) ** (5.0 / 3.0)) - t
                                         - t * (1.0 - t) ** (2.0 / 3.0))


def incipient_sliding_energy(approach: float, radius: float, contact_modulus: float,
                             friction: float) -> float:
    """E_tot = Σ f² p Δh = f² P a² / (5 R) (paper Eq. 27 with Δh = r²/(2R))."""
    return friction**2 * hertz.load(approach, radius, contact_modulus) * approach / 5.0


def unloading_approach(approach: float, radius: float, contact_modulus: float, amplitude: float,
                       tangential: float, friction: float) -> float:
    """δx on unloading from Q* to Q: δx(Q*) − 2 δx((Q* − Q)/2) (Mindlin–Deresiewicz)."""
    return (tangential_approach(approach, radius, contact_modulus, amplitude, friction)
            - 2.0 * tangential_approach(approach, radius, contact_modulus, (amplitude - tangential) / 2.0,
                                        friction))


def loop_energy(approach: float, radius: float, contact_modulus: float, amplitude: float,
                friction: float) -> float:
    """Energy dissipated per cycle between ±Q* (area of the Q–δx loop).

    ΔW = (24/5) f P δ0 [1 − (1 − t*)^(5/3) − (5 t*/6)(1 + (1 − t*)^(2/3))], t* = Q*/(fP),
    Mindlin & Deresiewicz's result (Johnson 1985, §7.3) written with δ0 = f a²/R, derived
    here from Masing's rule δx_unload(Q) = δx(Q*) − 2 δx((Q* − Q)/2); it equals 4 E_f(Q*).
    """
    t, p_load, delta0 = _ratio(approach, radius, contact_modulus, amplitude, friction)
    return 4.8 * friction * p_load * delta0 * (1.0 - (1.0 - t) ** (5.0 / 3.0)
                                               - 5.0 * t / 6.0 * (1.0 + (1.0 - t) ** (2.0 / 3.0)))
