"""Cyclic tangential loading (fretting) between ±Q* by the Cattaneo superposition with 2f.

After loading to Q* the contact is unloaded. Following Mindlin &
Deresiewicz for the sphere and Jäger's generalisation to any contact,
reversing the load adds to the state at the turning point a Cattaneo
correction with twice the friction coefficient:

    unloading Q* → Q:   q = q(Q*) − 2 f (p − p**),   δx = δx(Q*) − 2 f (δz − δz**),

with p** the normal solution at P** = P − (Q* − Q)/(2f) and the rotation of
the actual problem fixed (Eq. 23). The nodes outside the contact set of p**
slip back (q = −f p), the others stick. Reloading from −Q* mirrors it. Since
P** = P − u/f with u = (Q* − Q)/2 is the corrective load of the MONOTONIC
problem at Q = u, p** is the monotonic corrective solution at u: the cycle
needs no normal solve beyond the monotonic sweep to Q*, and Masing's rule
δx(Q) = δx(Q*) − 2 δx_mono((Q* − Q)/2) follows.

The energy dissipated per cycle is the area of the Q–δx loop; it is also
the sum over the nodes slipping back of f p̄ |Δg| with Δg = 2 f g** (the
same argument as Eq. 26 with 2f), which :class:`FrettingCycle` computes
independently so the two can be compared. The paper names fretting as the
main application of Eq. 27 (§5.2).

References: R.D. Mindlin, H. Deresiewicz, J. Appl. Mech. 20 (1953) 327–344;
J. Jäger, Wear 209 (1997) 210–220; K.L. Johnson, Contact Mechanics (1985) §7.3.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..normal.problem import NormalProblem
from ..normal.result import NormalResult
from .checks import check_friction, check_normal, check_steps, check_tangential
from .energy import frictional_energy, loop_area
from .sweep import TangentialSweep, tangential_sweep

LOADING, UNLOADING, RELOADING = 0, 1, 2


@dataclass(frozen=True)
class FrettingCycle:
    """First loading to Q*, then one full cycle Q* → −Q* → Q*.

    Path arrays have 3 (N + 1) points: loading (Q = u_k), unloading
    (Q = Q* − 2 u_k) and reloading (Q = −Q* + 2 u_k), u_k = k Q*/N.

    Attributes
    ----------
    amplitude
        Q* (N).
    loading
        The monotonic sweep 0 → Q* whose corrective solutions serve every branch.
    tangential, approach
        Q (N) and δx (m) along the path.
    branch
        0 loading, 1 unloading, 2 reloading.
    reverse_slip_area
        Area slipping since the last reversal (the slip area while loading), m².
    dissipated
        Energy dissipated by friction since Q = 0, J.
    loop_area
        ∮ Q dδx over unloading + reloading (trapezoidal rule), J.
    dissipated_per_cycle
        Σ f p̄ |Δg| over the nodes slipping back, unloading plus reloading, J.
    """

    amplitude: float
    loading: TangentialSweep
    tangential: np.ndarray
    approach: np.ndarray
    branch: np.ndarray
    reverse_slip_area: np.ndarray
    dissipated: np.ndarray
    loop_area: float
    dissipated_per_cycle: float

    @property
    def friction(self) -> float:
        return self.loading.friction

    @property
    def normal_load(self) -> float:
        return self.loading.normal.load

    @property
    def model(self) -> str:
        return self.loading.model

    @property
    def turning_point(self):
        """The monotonic state at Q*."""
        return self.loading.states[-1]

    def traction(self, index: int) -> np.ndarray:
        """Nodal shear force q̄ (N, along the load direction) at path point ``index``."""
        n = len(self.loading.states)
        if not 0 <= index < 3 * n:
            raise InputError("index", f"must lie in [0, {3 * n}), got {index!r}")
        branch, k = divmod(index, n)
        state = self.loading.states[k]
        if branch == LOADING:
            return state.traction
        sign = 1.0 if branch == UNLOADING else -1.0
        return reversal_traction(self.turning_point.traction, state.traction, sign)


def reversal_traction(turning: np.ndarray, correction: np.ndarray, sign: float) -> np.ndarray:
    """q = ±[q(Q*) − 2 f (p − p**)] after a load reversal (Mindlin–Deresiewicz, Jäger).

    ``correction`` is f (p − p**), the traction of the monotonic state whose
    corrective load is P**; ``sign`` is +1 unloading from +Q*, −1 reloading
    from −Q*.
    """
    return sign * (turning - 2.0 * correction)


def fretting_cycle(problem: NormalProblem, normal: NormalResult, friction: float, amplitude: float,
                   steps: int, direction=(1.0, 0.0), **solver_options) -> FrettingCycle:
    """Load to Q*, unload to −Q*, reload to Q*: the Q–δx hysteresis loop and its dissipation.

    Parameters
    ----------
    problem, normal
        The normal problem and its actual solution (load P, rotation).
    friction
        Coulomb coefficient f > 0.
    amplitude
        Q*, with 0 < Q* < fP.
    steps
        N intervals per branch.
    direction
        In-plane direction of +Q.
    **solver_options
        Options of the corrective solver (:class:`~.cattaneo.CattaneoSolver`).
    """
    friction = check_friction(friction)
    check_normal(problem, normal)
    amplitude = check_tangential(amplitude, friction, normal.load, name="amplitude")
    if amplitude == 0.0:
        raise InputError("amplitude", "must be > 0: a cycle between ±0 has no loop")
    steps = check_steps(steps)
    loads = amplitude * np.arange(steps + 1) / steps
    loading = tangential_sweep(problem, normal, friction, tangential=loads, direction=direction,
                               include_limit=False, **solver_options)
    states = loading.states
    turning = states[-1]
    u = loading.tangential
    approach = loading.approach
    area = np.array([s.slip_area for s in states])
    energy = np.array([s.frictional_energy for s in states])
    # energy dissipated slipping back by Δg = 2 f g** on the slip set of p** (Eq. 26 with 2f)
    reverse = np.array([frictional_energy(normal.force, 2.0 * np.nan_to_num(s.slip_distance), s.slip,
                                          friction) for s in states])
    tangential = np.concatenate([u, amplitude - 2.0 * u, -amplitude + 2.0 * u])
    path_approach = np.concatenate([approach, turning.tangential_approach - 2.0 * approach,
                                    -turning.tangential_approach + 2.0 * approach])
    n = u.size
    cycle = slice(n, 3 * n)
    return FrettingCycle(
        amplitude=amplitude, loading=loading, tangential=tangential, approach=path_approach,
        branch=np.repeat(np.array([LOADING, UNLOADING, RELOADING], dtype=np.int8), n),
        reverse_slip_area=np.concatenate([area, area, area]),
        dissipated=np.concatenate([energy, energy[-1] + reverse, energy[-1] + reverse[-1] + reverse]),
        loop_area=loop_area(tangential[cycle], path_approach[cycle]),
        dissipated_per_cycle=2.0 * float(reverse[-1]))
