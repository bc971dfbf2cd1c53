"""Arbitrary tangential load histories Q(t) at constant P: the memory rules of the discrete theorem.

Beyond first loading and one cycle (:mod:`.fretting`): Q(t) along a fixed
direction e with any number of reversals. With the discrete Cattaneo theorem
(Eqs. 21–24) the state on every branch is a superposition of monotonic
states C(X) = f (p − p*), p* the corrective normal solution at P − X/f
with the rotation fixed (Eq. 23):

- first loading (the virgin branch):   q = sgn Q · C(|Q|),             δx = sgn Q · δx(|Q|);
- after a reversal at Q_k (state q_k): q = q_k + σ · 2 C(|Q − Q_k|/2), δx = δx_k + σ · 2 δx(|Q − Q_k|/2),

σ the sign of the motion (Mindlin & Deresiewicz's superposition with 2f,
generalised by Jäger to any contact). Memory: a branch started at Q_n runs
until Q passes Q_{n−1}, where it rejoins the branch that was active before
the reversal at Q_{n−1}: the inner loop closes and both its branches are
forgotten (Masing's rules with memory). A branch from the first turning
point Q_1 rejoins the virgin curve at −Q_1. Each state therefore needs only
monotonic states, at X = |Q| or |Q − Q_k|/2 (one corrective normal solve
each, cached).

Energy: the nodes slipping on a branch slip by 2 f g*(X) (f g* the slip of
C(X), Eq. 26) under |q| = f p, so a branch dissipates 2 E_f(X) with E_f(X)
the monotonic frictional energy (E_f(|Q|) on the virgin branch). A closed
cycle between ±Q* dissipates 4 E_f(Q*), the Mindlin–Deresiewicz loop.

Valid where the Cattaneo construction is (β = γ = 0 exactly; the uncoupled
approximation otherwise, labelled) and for loads along one direction: a
history that turns the direction of Q has no superposition of this kind
(the coupled solver, :mod:`.coupled`, follows any path increment by increment).

References: R.D. Mindlin, H. Deresiewicz, J. Appl. Mech. 20 (1953) 327–344;
J. Jäger, Wear 209 (1997) 210–220 and Int. J. Solids Struct. 35 (1998)
1769–1781 (the memory rules for any axisymmetric and for general contacts);
K.L. Johnson, Contact Mechanics (1985) §7.3.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import require_finite
from ..errors import InputError
from ..normal.problem import NormalProblem
from ..normal.result import NormalResult
from .cattaneo import CattaneoSolver
from .checks import check_friction, check_normal, check_tangential
from .energy import loop_area
from .model import check_resticking
from .result import TangentialState

#: Digits of X / fP that tell two monotonic states apart (the corrective load's resolution is ~1e-13).
CACHE_DIGITS = 12


@dataclass(frozen=True)
class TangentialHistory:
    """States along a load history Q(t), starting from Q = 0 after normal loading.

    Attributes
    ----------
    tangential
        Q along e at each point (N, signed), the first point Q = 0.
    approach
        δx along e (m).
    dissipated
        Energy dissipated by friction since Q = 0 (J).
    slip_area
        Area slipping on the active branch (m²).
    memory
        Number of turning points remembered (0 on the virgin curve).
    tractions
        Nodal shear forces q̄ along e at each point (N).
    friction, normal, direction, model
        f, the actual normal solution, e and the Cattaneo model label.
    """

    tangential: np.ndarray
    approach: np.ndarray
    dissipated: np.ndarray
    slip_area: np.ndarray
    memory: np.ndarray
    tractions: tuple[np.ndarray, ...]
    friction: float
    normal: NormalResult
    direction: tuple[float, float]
    model: str

    def loop_energy(self, start: int, stop: int) -> float:
        """∮ Q dδx over points ``start`` … ``stop`` (a closed cycle: the energy it dissipates), J."""
        n = self.tangential.size
        if not 0 <= start < stop < n:
            raise InputError("start", f"need 0 <= start < stop < {n}, got ({start!r}, {stop!r})")
        return loop_area(self.tangential[start:stop + 1], self.approach[start:stop + 1])


@dataclass
class _Branch:
    """A branch of the Q–δx curve: from ``origin`` (Q, q̄, δx) with sign σ; virgin if ``factor`` is 1."""

    load: float
    traction: np.ndarray | None
    approach: float
    sign: float
    factor: float
    energy: float = 0.0            # the branch's dissipation when last evaluated

    @property
    def virgin(self) -> bool:
        return self.factor == 1.0

    def argument(self, q_load: float) -> float:
        """X of the monotonic state the branch needs at Q."""
        return abs(q_load) if self.virgin else abs(q_load - self.load) / 2.0


def tangential_history(problem: NormalProblem, normal: NormalResult, friction: float, loads,
                       direction=(1.0, 0.0), **solver_options) -> TangentialHistory:
    """States along Q(t) = ``loads`` (signed, along ``direction``) by the memory rules.

    Parameters
    ----------
    problem, normal
        The normal problem and its actual solution (load P, rotation).
    friction
        Coulomb coefficient f > 0.
    loads
        Q at successive times (N), each |Q| < fP; the path starts from Q = 0.
        States are exact at each point whatever the spacing; the spacing only
        sets the resolution of the Q–δx curve (and of :meth:`TangentialHistory.loop_energy`).
    direction
        In-plane direction e of Q.
    **solver_options
        Options of the corrective solver (:class:`~.cattaneo.CattaneoSolver`).
    """
    friction = check_friction(friction)
    check_normal(problem, normal)
    path = np.atleast_1d(np.asarray(loads, dtype=float))
    if path.ndim != 1 or path.size == 0:
        raise InputError("loads", "must be a non-empty sequence of tangential loads Q")
    for q in path:
        check_tangential(abs(require_finite("loads", q)), friction, normal.load, name="loads")
    path = np.concatenate([[0.0], path])
    with CattaneoSolver(problem, normal, friction, direction, **solver_options) as solver:
        # keyed on X / fP to 12 digits: the same X reached along different branches differs in its
        # last bits (0.0125 against 0.012499999999999997), and each miss is a corrective solve
        cache: dict[float, TangentialState] = {}

        def monotonic(x: float) -> TangentialState:
            key = round(x / solver.limit_load, CACHE_DIGITS)
            if key not in cache:
                cache[key] = solver.solve(x)
            return cache[key]

        def energy(branch: _Branch, x: float) -> float:
            return branch.factor * monotonic(x).frictional_energy

        current = _Branch(0.0, None, 0.0, 1.0, 1.0)
        stack: list[_Branch] = []
        motion = 0.0
        dissipated = 0.0
        states = []
        previous = None
        for k, q_load in enumerate(path):
            move = float(np.sign(q_load - path[k - 1])) if k else 0.0
            if move and motion and move != motion:
                # reversal at the previous point: it becomes the origin of a branch with 2f
                stack.append(current)
                current = _Branch(path[k - 1], previous[0], previous[1], move, 2.0,
                                  energy=0.0)
            if move:
                motion = move
            # memory: a branch that passes the turning point before its origin closes a loop
            while not current.virgin:
                parent = stack[-1]
                bound = -current.load if parent.virgin else parent.load
                if current.sign * (q_load - bound) < 0.0:
                    break
                dissipated += energy(current, current.argument(bound)) - current.energy
                stack.pop()
                current = stack.pop() if not parent.virgin else parent
            if current.virgin and q_load != 0.0:
                current.sign = float(np.sign(q_load))
            x = current.argument(q_load)
            state = monotonic(x)
            e_now = energy(current, x)
            dissipated += e_now - current.energy
            current.energy = e_now
            if current.virgin:
                traction = current.sign * state.traction
                approach = current.sign * state.tangential_approach
            else:
                traction = current.traction + current.sign * 2.0 * state.traction
                approach = current.approach + current.sign * 2.0 * state.tangential_approach
            previous = (traction, approach)
            states.append((q_load, approach, dissipated, state.slip_area, len(stack), traction))
        model = solver.model
    # every state superposes monotonic ones, whose stick sets must recede as X grows (Eq. 26)
    check_resticking([cache[key] for key in sorted(cache)], between="two monotonic states of the history")
    q, d, e, area, depth, tractions = zip(*states)
    return TangentialHistory(tangential=np.array(q), approach=np.array(d), dissipated=np.array(e),
                             slip_area=np.array(area), memory=np.array(depth), tractions=tuple(tractions),
                             friction=friction, normal=normal, direction=solver.direction, model=model)
