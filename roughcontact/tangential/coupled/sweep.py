"""Coupled sweeps of Q at constant P: the reference each uncoupled sweep is compared with."""
from __future__ import annotations

import time

from ...normal.problem import NormalProblem
from ...normal.result import NormalResult
from ..model import resticking_nodes
from ..sweep import sweep_loads
from .result import CoupledSweep
from .solver import CoupledTangentialSolver


def coupled_sweep(problem: NormalProblem, normal: NormalResult, friction: float, steps: int | None = None,
                  tangential=None, direction=(1.0, 0.0), **solver_options) -> CoupledSweep:
    """Coupled states for Q increasing from 0 towards fP, each an increment from the last (§4.1).

    Parameters
    ----------
    problem, normal
        The normal problem and its actual solution.
    friction
        Coulomb coefficient f > 0.
    steps
        N: the loads Q = k fP / N, k = 0 … N − 1 (as :func:`~..sweep.tangential_loads`).
    tangential
        Instead of ``steps``: increasing loads Q, each in [0, fP).
    direction
        In-plane direction of Q.
    **solver_options
        ``settings``, ``options``, ``prefix`` of :class:`~.solver.CoupledTangentialSolver`.
    """
    friction, loads = sweep_loads(problem, normal, friction, steps, tangential,
                                  "for a load history call CoupledTangentialSolver.solve load by load")
    t0 = time.perf_counter()
    with CoupledTangentialSolver(problem, normal, friction, direction, **solver_options) as solver:
        states = tuple(solver.solve(float(q)) for q in loads)
    return CoupledSweep(states=states, elapsed=time.perf_counter() - t0, resticking_nodes=resticking_nodes(states))
