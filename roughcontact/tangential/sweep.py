"""Sweeps of the tangential load Q from 0 to fP at constant P (§5, Figs. 9–12).

Each Q needs one corrective normal solve at P* = P − Q/f (Eq. 23); as Q
grows P* falls and the stick set recedes, so one corrective solver,
started each time from the line through the last two corrective solutions
(:class:`CattaneoSolver`), does each step in a few active-set iterations
(17–25 CG iterations at 513² on the whole footprint; 26–39 on the actual
contact set, where the corrective solves go when its explicit matrix pays,
and one more that confirms each on the footprint: :mod:`.contact_set`).
:class:`TangentialSweep` records the sweep's wall
time; ``benchmarks/bench_tangential.py`` measures it against a normal solve.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..normal.problem import NormalProblem
from ..normal.result import NormalResult
from .cattaneo import CattaneoSolver
from .checks import check_friction, check_normal, check_steps, check_tangential
from .energy import work
from .model import check_resticking
from .result import TangentialState


@dataclass(frozen=True)
class TangentialSweep:
    """Tangential states at increasing Q for one normal contact.

    Attributes
    ----------
    states
        One :class:`TangentialState` per Q, in increasing order; the last is
        the incipient-sliding limit Q → fP⁻ when the sweep included it.
    elapsed
        Wall time of the whole sweep (corrective solves and post-processing), s.
    resticking_nodes
        Largest number of nodes that joined the stick set from one step to the
        next. Zero when the stick sets recede (nest), which Eq. 26 assumes: a
        node that slipped and sticks again would keep its slip.
    """

    states: tuple[TangentialState, ...]
    elapsed: float
    resticking_nodes: int

    @property
    def normal(self) -> NormalResult:
        return self.states[0].normal

    @property
    def friction(self) -> float:
        return self.states[0].friction

    @property
    def model(self) -> str:
        return self.states[0].model

    @property
    def tangential(self) -> np.ndarray:
        """Q of each state (N)."""
        return np.array([s.tangential for s in self.states])

    @property
    def approach(self) -> np.ndarray:
        """δx of each state (Eq. 24), m."""
        return np.array([s.tangential_approach for s in self.states])

    @property
    def work(self) -> np.ndarray:
        """W = ∫ Q dδx from the first state (trapezoidal rule, :func:`~.energy.work`), J."""
        return work(self.tangential, self.approach)


def tangential_loads(friction: float, load: float, steps: int) -> np.ndarray:
    """Q_k = k fP / N for k = 0 … N − 1 (Q = fP itself is the incipient-sliding limit)."""
    steps = check_steps(steps)
    return friction * load * np.arange(steps) / steps


def sweep_loads(problem: NormalProblem, normal: NormalResult, friction: float, steps: int | None,
                tangential, reversals: str) -> tuple[float, np.ndarray]:
    """The checked friction and the increasing loads Q of a monotonic sweep.

    Either ``steps`` (Q = k fP / N, :func:`tangential_loads`) or
    ``tangential`` (a non-empty increasing list, each Q in [0, fP)), not both;
    ``reversals`` tells the user where non-monotonic loading goes.
    """
    friction = check_friction(friction)
    if (steps is None) == (tangential is None):
        raise InputError("steps", "give either steps (Q = k fP / N) or tangential (a list of Q), not both")
    check_normal(problem, normal)
    if steps is not None:
        return friction, tangential_loads(friction, normal.load, steps)
    loads = np.atleast_1d(np.asarray(tangential, dtype=float))
    if loads.size == 0:
        raise InputError("tangential", "is empty")
    for q in loads:
        check_tangential(q, friction, normal.load)
    if np.any(np.diff(loads) < 0.0):
        raise InputError("tangential", f"must be increasing (monotonic loading; {reversals})")
    return friction, loads


def tangential_sweep(problem: NormalProblem, normal: NormalResult, friction: float,
                     steps: int | None = None, tangential=None, direction=(1.0, 0.0),
                     include_limit: bool = True, **solver_options) -> TangentialSweep:
    """Partial-slip states for Q from 0 towards fP, each warm-started from the last (§5).

    Parameters
    ----------
    problem, normal
        The normal problem and its actual solution (load P, rotation).
    friction
        Coulomb coefficient f > 0.
    steps
        N: the loads Q = k fP / N, k = 0 … N − 1 (:func:`tangential_loads`).
    tangential
        Instead of ``steps``: increasing loads Q, each in [0, fP).
    direction
        In-plane direction of Q.
    include_limit
        Append the limit state Q → fP⁻ (:meth:`CattaneoSolver.incipient_sliding`),
        whose frictional energy is E_tot (Eq. 27).
    **solver_options
        ``method``, ``settings``, ``rtol``, ``options``, ``prefix`` of the
        corrective solver, and ``restrict`` (:class:`CattaneoSolver`).
    """
    friction, loads = sweep_loads(problem, normal, friction, steps, tangential,
                                  "for load reversals use fretting_cycle")
    t0 = time.perf_counter()
    with CattaneoSolver(problem, normal, friction, direction, **solver_options) as solver:
        states = [solver.solve(q) for q in loads]
        if include_limit:
            states.append(solver.incipient_sliding())
    elapsed = time.perf_counter() - t0
    resticking = check_resticking(states)
    return TangentialSweep(states=tuple(states), elapsed=elapsed, resticking_nodes=resticking)
