"""Primal–dual active set: near-full contact sets, free rotations with the forces (§3.1, Eqs. 7–11).

The bound-constrained CG (:mod:`.constrained_cg`) moves the contact set at
every step, and each move spoils the conjugacy of its directions. Near full
contact on large grids most of its iterations go to that settling: from a
coarse grid's start (Δ = 2.5, 1 E*) 27 / 34 / 47 fine iterations at 1024² /
2048² / 4096², of which the settled set alone takes 15–16 at 1024².

Here the set S is held while a preconditioned CG solves the flexibility
system on it, H_SS p_S = w_S (Eq. 11; under load control with Σ p = P, the
approach δz its multiplier), only to THETA times the residual the set started
from; then S moves at once, the paper's active-set rule (§3.1): the nodes of
S in tension leave it, their forces set to zero, and the nodes outside it
that interpenetrate enter. This is the primal–dual active set, a semismooth
Newton method on the contact conditions (Hintermüller, Ito & Kunisch, SIAM J.
Optim. 13 (2002) 865–888), with inexact inner solves: each set's residual
is about THETA of the last one's, and a set that no longer moves is solved
on to the tolerance by the same conjugate directions. Every set starts from
an exact H p in double precision (in the working precision on a coarse level
of a nested start); the products of the directions are taken in the working
precision (all in double after an exact H p fails to confirm
a set solved to the tolerance). The preconditioner is the constrained CG's
own (the Fourier preconditioner of the set, its edge correction and the hole
charge), its edge weights made for each set and the charge taken from the
first step on it, where the constrained CG takes the hole charge only once
its set has nearly stopped moving; or, on a set that takes it, the smooth
extension (:mod:`~roughcontact.operators.extension`), for which neither is
made.

It pays where the set is large (docs/solver-cost.md, "The contact set
settled by a primal–dual active set"): near full contact, one rank, the two
alternated in one process, 1024² 3.0–3.2 s against 3.6–3.8 s and 2048²
15.1–16.6 s against 19.9–20.6 s on three surfaces (2048²: 27 steps on 7
sets, 35 products, against 34 iterations). On the large-grid scene (a set
of 2–3 % of the grid) a scratch copy took 26 products against 17
iterations at 1024², and more time; from a quarter of the nodes in contact
it took less time than the constrained CG from fresh starts and, but for
one load, from a neighbour's along load sweeps (docs/solver-cost.md, "The
primal–dual steps from a quarter of the nodes in contact").
:class:`.ConstrainedCGSolver` takes it on levels of
``CGSettings.primal_dual_from`` nodes or more whose start holds at least
``CGSettings.primal_dual_share`` of the level's nodes in contact, fresh, or
``CGSettings.primal_dual_warm_share`` (any), warm.

With the rotation free (load control, the moments imposed; levels of
``CGSettings.rotation_from`` nodes or more, every level by default, from
any start and at any share in contact) the moments are two more
constraints of each set's solve, and (δz, θx, θy) are their multipliers
(:class:`_Motion`): the gap on S is H p − w less its least-squares fit by
C_S r (C's columns 1, −y, −x, Eq. 7), the directions are projected onto
the forces that keep the loads, and each new set's forces are corrected by
a rigid field to hold them exactly. The constrained CG finds the rotation
by a Newton iteration around solves at a fixed rotation instead, because
the moments as constraints of its every step lost the support at small
loads, where a few nodes surround the load point. Here a held set that
cannot carry them is either seen at once (its nodes on one line:
GRAM_CONDITION) or moves on, tension leaving, and the steps give up where
the sets cycle. That halves a free rotation's time: the large-grid scene
at 4096² 23.7 s against the Newton's 45.6 s, near full contact 49.8 s
against 92.7 s, an ensemble task's 12-load sweep at 513² 6.4–6.5 s against
12.6–13.4 s and at 17²–129² 0.49–0.87 of its time, the moments held to
round-off. On contacts of 3–4 nodes about the load point most sets cannot
carry the moments (28–30 of 30 cells at 1e-5 E* on 17² and 33²): the steps
give up at once, for 0.99–1.06 of the Newton's time. Where the steps give
up, the Newton goes on from their forces; its first evaluation, at a fixed
rotation, may take them again (``primal_dual_from``, ``primal_dual_share``
and ``primal_dual_warm_share``).

Without a globalisation the iteration may cycle between sets; it then gives
up (MAX_SETS sets, or MAX_STEPS steps on one set) and returns its forces,
clipped at zero, for the constrained CG to finish from (with the rotation
free, the Newton on θ of :mod:`.rigid_motion`). A loss of positive
curvature raises :class:`~roughcontact.errors.ConvergenceError`, as in the
constrained CG.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.linalg.blas import dgemv

from ..errors import ConvergenceError
from ..operators import passes
from ..operators.convolution import dense
from .problem import NormalProblem, node_indices

#: a set is solved to THETA times the residual it started from. Near full contact (Δ = 2.5, 1 E*,
#: the sets after a coarse grid's start), steps (+ sets) at 2048²: 0.01 28 (+7), 0.03 27 (+8),
#: 0.1 30 (+12); at 1024² 0.3 22 (+11), 0.03 24 (+7), 0.01 27 (+7)
THETA = 0.03
#: the passes the iteration may make before it gives up: one per set, and one more for each set
#: held to go on to the tolerance or confirmed on an exact H p
MAX_SETS = 40
#: the conjugate-gradient steps allowed on one set before it gives up
MAX_STEPS = 200
#: the largest condition of a set's C_Sᵀ C_S (C's columns 1, −y, −x) from which it holds imposed
#: moments: above it the set lies on a line, or nearly, and the steps give up for the Newton on θ
GRAM_CONDITION = 1e10


@dataclass
class Settled:
    """What :func:`settle` leaves: the forces (this rank's nodes), the deformed gap H p − w − C r of
    its last exact product where ``converged`` (else None), the rigid motion r = (δz, θx, θy) it
    found (the components held fixed 0: all without a load, the rotation without ``loads``), the
    products taken (the steps and each pass's exact H p), the residual each pass started from (a
    new set, a held one gone on with, or a confirmation) and whether the contact conditions hold
    to the tolerance."""

    forces: np.ndarray
    gap: np.ndarray | None
    motion: np.ndarray
    products: int
    history: list[float]
    converged: bool


def settle(problem: NormalProblem, forces: np.ndarray, w: np.ndarray | None, load: float | None, tol: float,
           single: bool, direction: Callable, weights: Callable,
           trace: Callable | None = None, forces_in_double: bool = True,
           loads: np.ndarray | None = None, start_only: bool = False, max_products: int | None = None) -> Settled:
    """The primal–dual active set from ``forces`` (this rank's nodes; changed in place).

    ``w``: the imposed interpenetration C r − gap0 with the approach left out under load control,
    None where it is −gap0; ``load``: P under load control, None under displacement control;
    ``tol``: the contact conditions' tolerance (the constrained CG's measure); ``single``: the
    products of the directions in single precision. ``direction(g, nodes, edge, single)`` is the
    preconditioned gap on the set ``nodes`` and gᵀz, ``weights(nodes, members, single)`` the edge
    weights of a set (both collective, from the constrained CG); ``trace(step, residual, changed,
    size, alpha, restart)``, if given, is told each step. ``forces_in_double`` False: the exact H p
    of the forces in the working precision too (a coarse level of a nested start, whose tolerance
    is 1000 times a single product's error; as the constrained CG's). ``loads``: with the rotation
    free, the loads (P, Σ p·(−y), Σ p·(−x)) the forces hold (Cᵀ p, Eq. 7's columns of C; ``load``
    their first, ``w`` None): the rotation is then found with the approach, on each set, as the
    constraints' multipliers (:class:`_Motion`), where the constrained CG finds it by a Newton
    iteration around solves at a fixed rotation. Each set's forces are then corrected to hold the
    moments, which may turn a few small ones at its edge negative: a state is returned only once
    none is, unless ``start_only`` (a coarse level of a nested start, whose state only starts the
    next level: there they are clipped to zero, and the extra sets they would take cost more than
    they give, 22 against 44 coarse iterations near full contact at 2048²). ``max_products``: the
    products (steps and exact H p) allowed before a ConvergenceError (``CG_MAX_ITERATIONS``, the
    constrained CG's ``max_iterations``); None: no bound but MAX_SETS and MAX_STEPS.
    """
    pb = problem
    if loads is not None and w is not None:
        raise ValueError("with the rotation free every component of the rigid motion is found: w must be None")
    workers = pb.flexibility.workers               # the threads of the passes over the nodes
    w_scale = pb.interpenetration_scale(pb.gap0 if w is None else w)
    found = _Motion(pb, load, loads, workers)
    found.rescale(forces)
    contact = forces > 0.0
    if not found.on(contact):
        return _unsettled(forces, 0, [])
    found.correct(forces)
    products, step, history = 0, 0, []
    lifted = None                                  # H p − w (C r not subtracted)
    exact = True                                   # the pass starts from an exact H p
    holding = False                                # the set held: the same directions go on to tol
    confirming = False                             # the exact H p confirms a set solved to tol
    searching = np.zeros_like(forces)              # the direction d on the set, zero elsewhere
    previous = None                                # gᵀz of the last step on the set (None: restart)
    changed = int(pb.allsum(np.count_nonzero(contact)))
    for _ in range(MAX_SETS):
        if exact:
            del lifted
            products = _spent(products, max_products, tol, history[-1] if history else None)
            lifted = pb.displacement(forces, single and not forces_in_double)
            if w is None:
                lifted += pb.gap0
            else:
                lifted -= w
        nodes = found.nodes                        # the set's nodes: flatnonzero(contact)
        size = int(pb.allsum(nodes.size))          # the set over all ranks (the trace's: every rank reduces)
        outside = ~contact
        g = passes.gather(lifted, nodes, workers)
        motion = found.fit(g)
        found.remove(g, motion)
        residual = float(pb.allmax(max(passes.largest_magnitude(g),
                                       found.interpenetration(lifted, outside, motion)))) / w_scale
        history.append(residual)
        if exact and residual <= tol and (start_only or found.signs_hold(forces)):
            lifted -= found.field(motion)
            if start_only and loads is not None:
                np.maximum(forces, 0.0, out=forces)    # a start: no force below zero
            return Settled(forces, lifted, motion, products, history, True)
        if confirming:
            # the steps' single-precision products left the set's gap off by more than tol
            single = False
        if holding:
            target = tol
        else:
            target = max(tol, THETA * residual)
            edge = weights(nodes, contact, single)
            passes.fill(searching, 0.0, workers)
            previous = None
        restart, steps = ("set" if previous is None else None), 0
        while True:                                # the CG on the set, to `target`
            reached = float(pb.allmax(passes.largest_magnitude(g))) / w_scale
            if reached <= target:
                break
            if steps == MAX_STEPS:
                return _unsettled(forces, products, history)
            z, gz = direction(g, nodes, edge, single)
            found.project_direction(z)              # gᵀz stays: g is projected already
            # d = z + β d_last, into z itself by a daxpy (z is this step's own)
            d = z if previous is None else passes.add_scaled(z, gz / previous,
                                                             passes.gather(searching, nodes, workers))
            del z
            previous = gz
            passes.scatter(searching, nodes, d, workers)
            products = _spent(products, max_products, tol, reached)
            product = pb.displacement(searching, single) if dense(nodes.size, forces.size) \
                else pb.displacement_at(d, nodes, single)
            on_set = passes.gather(product, nodes, workers)
            curvature = float(pb.allsum(d @ on_set))
            if not curvature > 0.0:
                raise ConvergenceError(
                    "CG_INDEFINITE", f"dᵀHd = {curvature:.3e} <= 0 on a set of {size} "
                                     f"nodes; the operator is not positive definite there")
            alpha = gz / curvature
            step += 1
            steps += 1
            if trace is not None:
                trace(step, reached, changed, size, alpha, restart)
            changed, restart = 0, None
            # d is zero off the set in ``searching``: a daxpy over the rank's nodes leaves the others
            # as they are, where the indexed update took 4 ms a step near full contact at 1024²
            forces = passes.add_scaled(forces, -alpha, searching)
            lifted = passes.add_scaled(lifted, -alpha, product)
            g = passes.add_scaled(g, -alpha, on_set)
            found.project(g)
            del d, product, on_set
        # the set moves: tension leaves, interpenetration enters (§3.1); the set's gap is taken
        # again at the top
        del g
        motion = found.fit(lifted[nodes])
        tension = contact & (forces < 0.0)
        entering = outside & (lifted < found.field(motion))
        changed = int(pb.allsum(np.count_nonzero(tension) + np.count_nonzero(entering)))
        if changed == 0:
            # the set holds: solved to tol, an exact H p confirms it; solved to its target, the
            # same directions go on to tol
            exact = confirming = reached <= tol
            holding = not exact
            continue
        forces[tension] = 0.0
        contact &= ~tension
        contact |= entering
        found.rescale(forces)
        nodes = None                               # the last set's indices go before the next's are made
        if not found.on(contact):
            return _unsettled(forces, products, history)
        found.correct(forces)
        exact, holding, confirming = True, False, False
    return _unsettled(forces, products, history)


def _spent(products: int, max_products: int | None, tol: float, last: float | None) -> int:
    """``products`` + 1, the product about to be taken; ConvergenceError (``CG_MAX_ITERATIONS``,
    as the constrained CG's) where that would pass ``max_products``."""
    if max_products is not None and products >= max_products:
        residual = "none yet" if last is None else format(last, ".3e")
        raise ConvergenceError(
            "CG_MAX_ITERATIONS", f"{max_products} primal-dual active-set products without meeting tol={tol:g} "
                                 f"(last residual {residual}); raise CGSettings.max_iterations or loosen tol")
    return products + 1


def _unsettled(forces: np.ndarray, products: int, history: list[float]) -> Settled:
    """What :func:`settle` leaves where it gives up: its forces clipped at zero, in place, for the
    constrained CG to go on from (with the rotation free, the Newton on θ)."""
    np.maximum(forces, 0.0, out=forces)
    return Settled(forces, None, np.zeros(3), products, history, False)


class _Motion:
    """The components of the rigid motion r = (δz, θx, θy) found with the forces on a contact set S
    (Eq. 7: C r = δz − θx y − θy x), as the multipliers of the loads the forces hold: none under
    displacement control; the approach δz under load control (Σ p = P), the mean of H p − w over S;
    with the moments imposed too (``loads``), the least-squares fit of C_S r to H p − w over S,
    C_S's columns 1, −y and −x at the nodes of S. The gap on S is H p − w less that fit, so it is
    orthogonal to the columns, and the directions are projected onto the forces that keep the
    loads (C_Sᵀ d = 0): the projected, preconditioned CG of an equality-constrained quadratic
    program (the preconditioned gap taken about its mean, as under load control, is the one-column
    case). Every sum is over all ranks."""

    def __init__(self, problem: NormalProblem, load: float | None, loads: np.ndarray | None, workers: int):
        self.problem, self.load, self.workers = problem, load, workers
        self.loads = None if loads is None else np.asarray(loads, dtype=float)
        if self.loads is not None and (load is None or self.loads[0] != load):
            raise ValueError("the moments are imposed under load control only, with loads[0] the load")
        self.nodes = None
        self.columns = None                        # C_S's columns −y and −x as rows (moments imposed)
        self.gram = self.scale = None              # C_Sᵀ C_S scaled to a unit diagonal, the scaling

    def on(self, nodes: np.ndarray) -> bool:
        """The contact set S from now on (this rank's node indices, or a mask over its nodes; the
        indices kept as ``nodes``); collective with the moments imposed. False where S cannot hold
        the moments: its nodes on one line or nearly (C_Sᵀ C_S's condition above GRAM_CONDITION),
        where a few nodes do not surround the load point."""
        self.nodes = self.columns = None           # the last set's, let go before the next's are made
        self.nodes = nodes = node_indices(nodes)
        if self.loads is None:
            return True
        pb = self.problem
        # −y and −x of the set's nodes as two rows, from the rows' and columns' coordinates (no
        # array of every node's)
        self.columns = pb.arms_at(nodes)
        sums = self.columns.sum(axis=1)
        gram = np.empty((3, 3))
        gram[0] = nodes.size, *sums
        gram[1:, 0] = sums
        gram[1:, 1:] = self.columns @ self.columns.T
        gram = pb.allsum(gram)
        if not np.all(np.diag(gram) > 0.0):           # no node, or all on the centroid's row or column
            return False
        # scaled to a unit diagonal: the coordinates' unit (m) must not count as conditioning
        self.scale = 1.0 / np.sqrt(np.diag(gram))
        self.gram = gram * np.outer(self.scale, self.scale)
        return bool(np.linalg.cond(self.gram) <= GRAM_CONDITION)

    def _solved(self, right: np.ndarray) -> np.ndarray:
        """(C_Sᵀ C_S)⁻¹ b, by the scaled Gram matrix."""
        return self.scale * np.linalg.solve(self.gram, self.scale * right)

    def _transposed(self, values: np.ndarray) -> np.ndarray:
        """C_Sᵀ v over all ranks, for v on the nodes of S (one pass over v for its two moments:
        BLAS's dgemv)."""
        return self.problem.allsum(np.concatenate(([values.sum()], self.columns @ values)))

    def _on_set(self, motion: np.ndarray) -> np.ndarray:
        """C_S r on the nodes of S."""
        values = self.columns.T @ motion[1:]
        values += motion[0]
        return values

    def fit(self, values: np.ndarray) -> np.ndarray:
        """r fitted to ``values`` on the nodes of S (H p − w there): (δz, θx, θy), 0 where not found."""
        if self.load is None:
            return np.zeros(3)
        if self.loads is None:
            return np.array([self.problem.allmean(values), 0.0, 0.0])
        return self._solved(self._transposed(values))

    def remove(self, values: np.ndarray, motion: np.ndarray) -> None:
        """values −= C_S r on the nodes of S, in place."""
        if self.loads is None:
            values -= motion[0]
        else:
            # v ← v − [−y −x] (θx, θy) in place (BLAS's dgemv, which takes no empty v), then less δz
            if values.size:
                moved = dgemv(-1.0, self.columns.T, motion[1:], beta=1.0, y=values, overwrite_y=True)
                if moved is not values:            # a strided or non-float64 v is copied by BLAS
                    values[...] = moved
            passes.combine(np.subtract, values, motion[0], values, self.workers)

    def project(self, values: np.ndarray) -> None:
        """values less their fit (values on the nodes of S, in place): the gap kept orthogonal to
        the columns along the steps."""
        if self.load is None:
            return
        if self.loads is None:
            passes.combine(np.subtract, values, self.problem.allmean(values), values, self.workers)
        else:
            self.remove(values, self.fit(values))

    def project_direction(self, values: np.ndarray) -> None:
        """A preconditioned gap projected onto the forces that keep the moments (in place); with
        the rotation fixed the direction's mean is taken off where it is made (the constrained
        CG's ``_direction``)."""
        if self.loads is not None:
            self.project(values)

    def field(self, motion: np.ndarray):
        """C r on this rank's nodes (a scalar where only δz is found)."""
        if self.loads is None:
            return motion[0]
        return self.problem.rigid_displacement(motion)

    def interpenetration(self, lifted: np.ndarray, outside: np.ndarray, motion: np.ndarray) -> float:
        """The deepest interpenetration off S, max(C r − (H p − w)) there (0 for none): this rank's."""
        if self.loads is None:
            return motion[0] - lifted[outside].min(initial=motion[0])
        depth = self.field(motion)
        depth -= lifted
        return float(np.max(depth, where=outside, initial=0.0))

    def rescale(self, forces: np.ndarray) -> None:
        """The forces rescaled to the load P (Polonsky & Keer), in place; collective."""
        if self.load is not None:
            forces *= self.problem.load_scale(forces, self.load)

    def correct(self, forces: np.ndarray) -> None:
        """With the moments imposed, the forces (rescaled to P) corrected on S by C_S a so that
        C_Sᵀ p holds the loads exactly, in place (small forces at the set's edge may turn
        negative: the next move takes them out); collective."""
        if self.loads is not None:
            held = forces[self.nodes]
            correction = self._solved(self.loads - self._transposed(held))
            held += self._on_set(correction)
            forces[self.nodes] = held

    def signs_hold(self, forces: np.ndarray) -> bool:
        """Whether no force on S is negative, the same answer on every rank; with the rotation
        fixed, True without a look (the set's forces are then never negative at an exact pass: a
        move takes tension out and only rescales)."""
        if self.loads is None:
            return True
        return not self.problem.allsum(np.count_nonzero(forces[self.nodes] < 0.0))
