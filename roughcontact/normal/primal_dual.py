"""Near full contact: the contact set settled by a primal–dual active set (§3.1, Eqs. 7–11).

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
its set has nearly stopped moving.

It pays where the set is large (docs/solver-cost.md, "The contact set
settled by a primal–dual active set"): near full contact, one rank, the two
alternated in one process, 1024² 3.0–3.2 s against 3.6–3.8 s and 2048²
15.1–16.6 s against 19.9–20.6 s on three surfaces (2048²: 27 steps on 7
sets, 35 products, against 34 iterations). On the large-grid scene (a set
of 2–3 % of the grid) a scratch copy took 26 products against 17
iterations at 1024², and more time. :class:`.ConstrainedCGSolver` takes it
on the fresh solves (with a free rotation, on its Newton's first
evaluation) of levels of
``CGSettings.primal_dual_from`` nodes or more whose start holds at least
PRIMAL_DUAL_SHARE of the level's nodes in contact.

Without a globalisation the iteration may cycle between sets; it then gives
up (MAX_SETS sets, or MAX_STEPS steps on one set) and returns its forces,
clipped at zero, for the constrained CG to finish from. A loss of positive
curvature raises :class:`~roughcontact.errors.ConvergenceError`, as in the
constrained CG.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import ConvergenceError
from ..operators import passes
from ..operators.convolution import dense
from .problem import NormalProblem

#: a set is solved to THETA times the residual it started from. Near full contact (Δ = 2.5, 1 E*,
#: the sets after a coarse grid's start), steps (+ sets) at 2048²: 0.01 28 (+7), 0.03 27 (+8),
#: 0.1 30 (+12); at 1024² 0.3 22 (+11), 0.03 24 (+7), 0.01 27 (+7)
THETA = 0.03
#: the passes the iteration may make before it gives up: one per set, and one more for each set
#: held to go on to the tolerance or confirmed on an exact H p
MAX_SETS = 40
#: the conjugate-gradient steps allowed on one set before it gives up
MAX_STEPS = 200
#: the share of a level's nodes in contact from which its start counts as near full contact
PRIMAL_DUAL_SHARE = 0.5


@dataclass
class Settled:
    """What :func:`settle` leaves: the forces (this rank's nodes), the deformed gap H p − w − δz of
    its last exact product where ``converged`` (else None), the approach δz (0 without a load),
    the products taken (the steps and each pass's exact H p), the residual each pass started from
    (a new set, a held one gone on with, or a confirmation) and whether the contact conditions
    hold to the tolerance."""

    forces: np.ndarray
    gap: np.ndarray | None
    approach: float
    products: int
    history: list[float]
    converged: bool


def settle(problem: NormalProblem, forces: np.ndarray, w: np.ndarray | None, load: float | None, tol: float,
           single: bool, direction: Callable, weights: Callable,
           trace: Callable | None = None, forces_in_double: bool = True) -> Settled:
    """The primal–dual active set from ``forces`` (this rank's nodes; changed in place).

    ``w``: the imposed interpenetration C r − gap0 with the approach left out under load control,
    None where it is −gap0; ``load``: P under load control, None under displacement control;
    ``tol``: the contact conditions' tolerance (the constrained CG's measure); ``single``: the
    products of the directions in single precision. ``direction(g, nodes, edge, single)`` is the
    preconditioned gap on the set ``nodes`` and gᵀz, ``weights(nodes, members, single)`` the edge
    weights of a set (both collective, from the constrained CG); ``trace(step, residual, changed,
    size, alpha, restart)``, if given, is told each step. ``forces_in_double`` False: the exact H p
    of the forces in the working precision too (a coarse level of a nested start, whose tolerance
    is 1000 times a single product's error; as the constrained CG's).
    """
    pb = problem
    workers = pb.flexibility.workers               # the threads of the passes over the nodes
    loaded = load is not None
    w_scale = pb.interpenetration_scale(pb.gap0 if w is None else w)
    if loaded:
        forces *= pb.load_scale(forces, load)
    contact = forces > 0.0
    products, step, history = 0, 0, []
    lifted = None                                  # H p − w (δz not subtracted)
    exact = True                                   # the pass starts from an exact H p
    holding = False                                # the set held: the same directions go on to tol
    confirming = False                             # the exact H p confirms a set solved to tol
    searching = np.zeros_like(forces)              # the direction d on the set, zero elsewhere
    previous = None                                # gᵀz of the last step on the set (None: restart)
    changed = int(pb.allsum(np.count_nonzero(contact)))
    for _ in range(MAX_SETS):
        if exact:
            del lifted
            lifted = pb.displacement(forces, single and not forces_in_double)
            if w is None:
                lifted += pb.gap0
            else:
                lifted -= w
            products += 1
        nodes = np.flatnonzero(contact)
        size = int(pb.allsum(nodes.size))          # the set over all ranks (the trace's: every rank reduces)
        outside = ~contact
        g = passes.gather(lifted, nodes, workers)
        approach = pb.allmean(g) if loaded else 0.0
        g -= approach
        residual = float(pb.allmax(max(passes.largest_magnitude(g),
                                       approach - lifted[outside].min(initial=approach)))) / w_scale
        history.append(residual)
        if exact and residual <= tol:
            lifted -= approach
            return Settled(forces, lifted, approach, products, history, True)
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
            # d = z + β d_last, into z itself by a daxpy (z is this step's own)
            d = z if previous is None else passes.add_scaled(z, gz / previous,
                                                             passes.gather(searching, nodes, workers))
            del z
            previous = gz
            passes.scatter(searching, nodes, d, workers)
            product = pb.displacement(searching, single) if dense(nodes.size, forces.size) \
                else pb.displacement_at(d, nodes, single)
            products += 1
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
            if loaded:
                passes.combine(np.subtract, g, pb.allmean(g), g, workers)
            del d, product, on_set
        # the set moves: tension leaves, interpenetration enters (§3.1)
        approach = pb.allmean(lifted[nodes]) if loaded else 0.0
        tension = contact & (forces < 0.0)
        entering = outside & (lifted < approach)
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
        if loaded:
            forces *= pb.load_scale(forces, load)
        exact, holding, confirming = True, False, False
    return _unsettled(forces, products, history)


def _unsettled(forces: np.ndarray, products: int, history: list[float]) -> Settled:
    """What :func:`settle` leaves where it gives up: its forces clipped at zero, in place, for the
    constrained CG to go on from."""
    np.maximum(forces, 0.0, out=forces)
    return Settled(forces, None, 0.0, products, history, False)
