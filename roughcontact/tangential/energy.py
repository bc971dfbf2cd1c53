"""Energies of partial slip: friction (Eqs. 26–27), elastic storage, work and loop area (§5.2).

Under a monotonically increasing Q a node that slips carries q = f p from
the moment it enters the slip set, so the energy it dissipates is exactly
f p̄ g (Eq. 26) with g its slip so far; at incipient full sliding g = f Δh
with Δh the undeformed gap at first touch (Eq. 27). The tangential elastic
energy is U = ½ qᵀ H q (Eq. 17 has the kernel of the normal problem when
γ = 0). The work of Q along δx balances the two, W = ∫ Q dδx = U + E_f,
which the tests check; W is evaluated here by the trapezoidal rule.
"""
from __future__ import annotations

import numpy as np


def frictional_energy(force: np.ndarray, slip_distance: np.ndarray, slip: np.ndarray,
                      friction: float) -> float:
    """E_f = Σ_slip f p̄ g (Eq. 26), J.

    Parameters
    ----------
    force
        Nodal normal forces p̄ (N).
    slip_distance
        Slip g (m) on the slip set (other values are ignored).
    slip
        Boolean slip set.
    friction
        f.
    """
    return float(friction * np.sum(force[slip] * slip_distance[slip]))


def stored_energy(traction: np.ndarray, displacement: np.ndarray) -> float:
    """U = ½ Σ q̄ u_x with u_x = H q̄ (Eq. 17), J; nodes without traction do not count."""
    loaded = traction != 0.0
    return float(0.5 * np.sum(traction[loaded] * displacement[loaded]))


def work(tangential, approach) -> np.ndarray:
    """Cumulative W_k = ∫ Q dδx from the first point to point k (trapezoidal rule), J.

    The discrete δx(Q) is piecewise linear in Q (linear while the stick set
    does not change), so the rule is exact on each interval without a change
    of stick set and second order, O(ΔQ²), over a sweep whose stick set
    changes often. Near Q = fP, dδx/dQ grows like (1 − Q/fP)^(−1/3) (Hertz)
    and the last interval dominates the error.
    """
    q = np.asarray(tangential, dtype=float)
    d = np.asarray(approach, dtype=float)
    increments = 0.5 * (q[1:] + q[:-1]) * np.diff(d)
    return np.concatenate([[0.0], np.cumsum(increments)])


def loop_area(tangential, approach) -> float:
    """∮ Q dδx around a closed path (trapezoidal rule; the path is closed if it is not), J.

    Positive for a loop traversed as a fretting cycle is (unloading above
    reloading in the Q–δx plane): the energy dissipated per cycle.
    """
    q = np.asarray(tangential, dtype=float)
    d = np.asarray(approach, dtype=float)
    q_closed = np.append(q, q[0])
    d_closed = np.append(d, d[0])
    return float(np.sum(0.5 * (q_closed[1:] + q_closed[:-1]) * np.diff(d_closed)))
