"""Load control as a damped Newton iteration on the rigid-body motion (Eqs. 7–8).

The loads conjugate to the rigid motion r = (δz, θx, θy) are its gradient of
the convex function

    Φ(r) = max_{p ≥ 0} [pᵀ w(r) − ½ pᵀ H p] − r_freeᵀ L_free = ½ p*ᵀ w − r_freeᵀ L_free,

F = C_freeᵀ p* − L_free, with w = C r − gap0 (Eq. 7) and C = [1, −y, −x]
(Eq. 8). Newton iterates on some of the free components (``outer``); the
others (``inner``) may be found inside each evaluation, which then returns a
state of zero inner residual: Φ minimised over them is still convex, its
gradient is the outer residual and its Hessian the Schur complement over the
inner components of K = C_Sᵀ H_SS⁻¹ C_S (the active set: K itself, |free|
solves on the contact set S; the CG: C_θᵀ X from two solves of the forces'
response X to the rotations at a constant load). On a fixed S, p is
linear in r and the step is exact once S has settled. Far from it, a trust
region bounds the step (and steers it along directions the contact set does
not stiffen yet), the step below the imposed load is the one of Newton on
log P (:func:`log_damping`), and an Armijo line search on Φ, or a halving of
the load residual near the solution where Φ's decrease drowns in round-off,
accepts it. Evaluations may be inexact (an inexact Newton: the CG resolves each
state only as far as the step from it needs); Φ is then the inner problem's
value at the state's forces, off by second-order terms only, and a state that
meets the load tolerance is confirmed on one resolved for it. Updating S and r
together instead, as one active set, cycles on rough surfaces with free
rotations. The primal–dual steps of the constrained CG do find r with the
forces (:mod:`.primal_dual`; by default on every grid,
``CGSettings.rotation_from``): each set held while the rotation is fitted on
it, and this Newton taking over where a set cannot carry the moments or the
sets cycle.

Failure is never silent: a line search that finds no decrease, or too many
Newton steps, raise :class:`~roughcontact.errors.ConvergenceError`.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import ConvergenceError
from .problem import NormalProblem
from .result import ContactState

#: relative round-off of Φ = ½ pᵀw − ½ pᵀg − rᵀL: a rise below it is no rise
PHI_ROUNDOFF = 1e-10
#: the inner tolerance of an inexact evaluation is at least this share of load_tol
#: (:class:`InexactResolution`): the moments of a state resolved to r were off by 0.0016-2.8 r
#: (r = 1e-11 to 1e-7; 10 states: the large-grid scene and near full contact at 256², an
#: ensemble task's at 65² and 129²; benchmarks/bench_rotation.py), so 0.1 keeps them within
#: 0.28 load_tol. The share was 1e-3: the last evaluation took 7 and 9 CG iterations near full
#: contact and on the scene at 1024², where 0.1 takes 1 and 5
CONFIRM_SHARE = 0.1
#: ... lowered a hundredfold, to this, where the states so resolved stop the Newton's progress
FINEST_SHARE = 1e-3

Evaluate = Callable[[np.ndarray, float], tuple[ContactState, np.ndarray]]
Stiffness = Callable[[np.ndarray], tuple[np.ndarray, int]]
Resolution = Callable[[float], float]


def newton_on_motion(problem: NormalProblem, rigid: np.ndarray, free: list[int], outer: list[int],
                     loads: np.ndarray, evaluate: Evaluate, stiffness: Stiffness,
                     load_tol: float, max_newton: int,
                     resolution: Resolution | None = None,
                     tighten: Callable[[], bool] | None = None) -> tuple[ContactState, np.ndarray]:
    """The contact state whose loads C_freeᵀ p equal ``loads[free]``, and its rigid motion.

    Parameters
    ----------
    problem
        The normal problem.
    rigid
        Start: imposed components, and the first guess of the free ones.
    free
        Components found from their loads (δz = 0, θx = 1, θy = 2).
    outer
        The free components Newton updates; the others are found by ``evaluate``.
    evaluate
        ``evaluate(r, needed) -> (state, r)``: the contact state with the components of
        r not in ``free − outer`` imposed, and r completed; ``needed`` is the relative load
        residual the iteration stands at (inf before the first), from which an inexact
        evaluation chooses how far to resolve the state (an inexact Newton).
    stiffness
        ``stiffness(S) -> (K, iterations)``: the Hessian of Φ over ``outer`` (|outer| × |outer|),
        Φ minimised over the others: the Schur complement of C_Sᵀ H_SS⁻¹ C_S over them.
    load_tol, max_newton
        Stop when every outer load residual is within ``load_tol`` of P (moments:
        of P times the footprint's half-size); raise after ``max_newton`` steps.
    resolution
        For inexact evaluations, ``resolution(needed)``: the inner tolerance ``evaluate``
        resolves a state to for ``needed`` (None: every evaluation is exact). A state that
        meets ``load_tol`` but was resolved more loosely than for ``load_tol`` is evaluated
        again for it before it is returned, and a state the line search cannot improve is
        resolved for its own residual first when that is tighter than it was resolved for.
    tighten
        For inexact evaluations whose ``resolution`` has a floor (``resolution(0)``,
        :class:`InexactResolution`): ``tighten()`` lowers it and says whether it could. A state the
        line search cannot improve and that its own residual would not resolve more tightly,
        or a step from a state resolved at the floor that did not halve the load residual,
        is resolved again below the lowered floor.
    """
    def looser(resolved_for: float, than: float) -> bool:
        """Whether a state resolved for ``resolved_for`` is resolved more loosely than for ``than``."""
        return resolution is not None and resolution(resolved_for) > resolution(than)

    def lowered(resolved_for: float) -> bool:
        """Whether a state resolved for ``resolved_for`` sat on the resolution's floor, and the
        floor was lowered below it."""
        return (tighten is not None and resolution is not None
                and resolution(resolved_for) <= resolution(0.0) and tighten())

    target = loads[outer]
    extent = problem.extent
    scale = np.array([loads[0], loads[0] * extent, loads[0] * extent])[outer]
    height = max(problem.height_range, abs(rigid[0]), 1e-12 * extent)
    units = np.array([height, height / extent, height / extent])[outer]
    radius = 1.0
    history: list[float] = []
    spent = {"outer": 0, "linear": 0}                  # evaluations and linear iterations, all counted

    def relative(force: np.ndarray) -> float:
        """The load residual: the largest of F over its scale (P; P × half-size for moments)."""
        return float(np.max(np.abs(force) / scale))

    def evaluated(r, needed):
        """(state, r, Φ, F) at r resolved for ``needed``, its iterations counted."""
        result = _evaluate(problem, r, free, outer, loads, evaluate, needed)
        spent["outer"] += result[0].outer
        spent["linear"] += result[0].linear
        return result

    needed = np.inf                                    # the load residual the state was resolved for
    state, rigid, phi, force = evaluated(rigid, needed)
    for newton in range(1, max_newton + 1):
        error = relative(force)
        if error <= load_tol and looser(needed, load_tol):   # met on a state resolved more loosely:
            needed = load_tol                                # confirm on one resolved for load_tol
            state, rigid, phi, force = evaluated(rigid, needed)
            error = relative(force)
        history.append(error)
        if error <= load_tol:
            return state._replace(outer=spent["outer"], linear=spent["linear"], history=tuple(history),
                                  residual=max(state.residual, error)), rigid
        hessian, its = stiffness(state.active)
        spent["linear"] += its
        # a direction the set does not stiffen is not followed where the residual along it is
        # within half of load_tol: the stiff steps then meet load_tol, with room for round-off
        newton_step = _newton_step(hessian, force, units, radius, 0.5 * load_tol * scale)
        step = newton_step * (log_damping(force[0] + target[0], target[0]) if outer[0] == 0 else 1.0)
        slope = float(force @ step)
        alpha = 1.0
        while True:
            trial = rigid.copy()
            trial[outer] = rigid[outer] + alpha * step
            t_state, t_rigid, t_phi, t_force = evaluated(trial, error)
            t_error = relative(t_force)
            # Armijo on Φ; near the solution Φ's decrease is below its round-off, and a
            # decrease of the load residual itself is accepted instead — only while Φ does not
            # rise above its round-off: the two criteria otherwise take turns and cycle
            if (t_phi <= phi + 1e-4 * alpha * slope
                    or (t_error <= 0.5 * error and t_phi <= phi + PHI_ROUNDOFF * abs(phi))
                    or alpha < 1e-6):
                break
            alpha *= 0.5
        if alpha < 1e-6 and (looser(needed, error) or lowered(needed)):
            # the state was resolved for the larger residual of the step before, or at the floor
            # of the resolution: its loads and Φ may be off by more than this step can gain.
            # Resolve it for its own residual (below the lowered floor), go on (each retry
            # resolves more tightly than the last, and the floor has a bottom, so they end)
            needed = error
            state, rigid, phi, force = evaluated(rigid, needed)
            continue
        if alpha < 1e-6:
            if error <= 1e3 * load_tol:
                advice = ("the contact state is resolved more coarsely than load_tol: loosen it, or "
                          "tighten the inner solves")
            else:
                advice = (f"the iteration stalled far from the imposed loads at rotation "
                          f"({rigid[1]:.3g}, {rigid[2]:.3g}) rad; free rotations that must tilt the body by "
                          "more than its roughness to bring nodes around the load point leave the small "
                          "rotations of Eq. 7: fix the rotation (rotation=(0, 0)) or check the load point")
            raise ConvergenceError(
                "LOAD_CONTROL_LINE_SEARCH",
                f"Newton step {newton} on the rigid motion found no decrease of the complementary energy, "
                f"nor a halving of the load residual ({error:.3e}) that kept it from rising; {advice}")
        # the trust region follows Newton's own step: the log-P damping is not a sign of distrust
        moved = float(np.max(np.abs(alpha * newton_step) / units))
        radius = 4.0 * radius if alpha == 1.0 and moved >= 0.99 * radius else max(moved, 1e-3)
        rigid, state, phi, force, needed = t_rigid, t_state, t_phi, t_force, error
        if t_error > max(load_tol, 0.5 * error) and lowered(error):
            # a step from a state resolved at the floor that did not halve the residual nor meet
            # load_tol: near the solution Newton's steps leave about e², so the states' moments
            # are off by more than the steps gain. Resolve the new state below the lowered floor
            state, rigid, phi, force = evaluated(rigid, needed)
    raise ConvergenceError(
        "LOAD_CONTROL_MAX_ITERATIONS",
        f"{max_newton} Newton steps on the rigid motion without meeting load_tol={load_tol:g} "
        f"(last relative load residual {history[-1]:.3e}); raise the solver's max_newton")


def _evaluate(problem, rigid, free, outer, loads, evaluate, needed):
    """The state at r; Φ(r) and its outer gradient F = C_outerᵀ p − L_outer.

    Φ is the value of the inner problem at the state's forces, pᵀw − ½ pᵀHp − r_freeᵀL_free
    = ½ pᵀw − ½ pᵀg − r_freeᵀL_free (g the gap, Hp = g + w): ½ pᵀw alone is the same at the exact
    solution, but off it by ½ pᵀg, first order in the inner residual, where the value is off by
    second order terms on the contact set (p maximises it there). Without the correction an
    inexact evaluation's Φ drowned Armijo's decrease.
    """
    state, rigid = evaluate(rigid, needed)
    w = problem.interpenetration(rigid)
    # Cᵀp = (Σp, −Σ y p, −Σ x p) (Eq. 8), from the moments by rows and columns
    loaded = problem.moments(state.pressure) * np.array([1.0, -1.0, -1.0])
    sums = problem.allsum(np.append(loaded[outer], 0.5 * state.pressure @ w))
    force = sums[:-1] - loads[outer]
    phi = float(sums[-1] - 0.5 * state.slack - rigid[free] @ loads[free])
    return state, rigid, phi, force


def log_damping(load: float, target: float) -> float:
    """Scale of the Newton step below the imposed load: the step of Newton on log P.

    P(δz) increases and is convex as the contact set grows (exponential on
    rough surfaces, δz^1.5 on a sphere), so Newton on P from below overshoots,
    taking the contact set far past its size at the solution (at 128², 0.05
    E*: 183 → 5790 nodes, then back to 1490). log P is about linear in δz on
    rough surfaces and concave on power laws, and Newton on it from below does
    not overshoot; in one dimension its step is Newton's times
    P ln(P*/P) / (P* − P) < 1. Above the load, or without contact, Newton's
    own step is kept (from above it converges monotonically on a convex P).
    """
    if not 0.0 < load < target:
        return 1.0
    return load * np.log(target / load) / (target - load)


def _newton_step(hessian: np.ndarray, force: np.ndarray, units: np.ndarray, radius: float,
                 negligible: np.ndarray) -> np.ndarray:
    """Newton step on Φ within a trust region, robust to a contact set that cannot fix r yet.

    In coordinates u = dr / units the step solves the Newton system on the
    range of the Hessian; along directions the contact set does not stiffen
    yet (no node touches, or too few to fix a rotation), Φ is linear, and the
    step follows its descent direction, unless the loads' residual along them
    is within ``negligible`` (in F's units, each load's: a share of load_tol
    times the load's scale): two nodes on a line through the load point carry
    the moments but not the rotation about that line, along which F is
    round-off, and a step of the whole radius there moved the set off its
    solution at every try (the line search then failed at 2.05e-8 against
    load_tol 1e-8, on one rank). The step is then limited to |u|∞ ≤ radius.
    """
    gradient = force * units
    matrix = hessian * np.outer(units, units)
    values, vectors = np.linalg.eigh(matrix)
    stiff = values > 1e-10 * max(values.max(initial=0.0), 0.0) if values.max(initial=0.0) > 0 else \
        np.zeros(values.size, bool)
    step = -(vectors[:, stiff] @ ((vectors[:, stiff].T @ gradient) / values[stiff]))
    soft = vectors[:, ~stiff]
    if soft.size:
        descent = -(soft @ (soft.T @ gradient))
        if np.any(np.abs(descent / units) > negligible):
            step += radius * descent / np.abs(descent).max()
    longest = np.abs(step).max()
    if longest > radius:
        step *= radius / longest
    return step * units


class InexactResolution:
    """The inner tolerance an inexact Newton resolves a state to, for the load residual e it
    stands at (``needed``): min(tol, max(1e-3 e², share × load_tol)).

    The step from a residual e leaves about e², so the state it steps from need resolve its
    moments only 1000 times below e²; the floor, share × load_tol with the share
    :data:`CONFIRM_SHARE`, holds the last states (e² below load_tol), whose moments must meet
    load_tol, close enough for that. :meth:`tighten` lowers the share a hundredfold, down to
    :data:`FINEST_SHARE`, where a state so resolved is still too far off. The first evaluation
    (e = inf, the start's residual unknown) is resolved to max(tol, ``first``).
    """

    def __init__(self, tol: float, load_tol: float, first: float):
        self.tol, self.load_tol, self.first = tol, load_tol, first
        self.share = CONFIRM_SHARE

    def __call__(self, needed: float) -> float:
        if needed == np.inf:
            return max(self.tol, self.first)
        return min(self.tol, max(1e-3 * needed ** 2, self.share * self.load_tol))

    def tighten(self) -> bool:
        """Lower the floor a hundredfold; False where it is at :data:`FINEST_SHARE` already."""
        if self.share <= FINEST_SHARE:
            return False
        self.share = max(self.share / 100.0, FINEST_SHARE)
        return True
