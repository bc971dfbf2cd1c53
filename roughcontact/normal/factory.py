"""Normal solvers by name, and the method-agnostic load and closure sweeps (§3.1).

:func:`make_solver` resolves ``"auto"`` (:func:`~.choice.choose_method`) and
builds the solver of the method: the active set (:mod:`.active_set`, inner
solves by PETSc Krylov or the paper's Gauss–Seidel) or the bound-constrained
CG (:mod:`.constrained_cg`). Options a solver does not take are refused here,
naming them, before anything is built. :func:`solve_loads` and
:func:`solve_closures` run one solver over increasing loads or closures,
each solve warm-started from the last.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from .active_set import ActiveSetSolver
from .choice import ACTIVE_SET_METHODS, choose_method
from .constrained_cg import ConstrainedCGSolver
from .problem import NormalProblem
from .result import NormalResult
from .solver import NormalSolver


def solver_class(method: str) -> type[NormalSolver]:
    """The class that solves with ``method`` (a resolved name, not ``"auto"``)."""
    return ActiveSetSolver if method in ACTIVE_SET_METHODS else ConstrainedCGSolver


def make_solver(problem: NormalProblem, method: str = "auto", **options) -> NormalSolver:
    """A normal solver of ``problem`` by name: ``"auto"`` (:func:`~.choice.choose_method`),
    ``"ksp"``, ``"gauss-seidel"`` or ``"cg"``.

    ``options`` go to the solver's constructor (its ``OPTIONS``: settings,
    tolerances, PETSc options and prefix for the active set; settings and
    the nested start for the CG); one it does not take is an
    :class:`InputError` naming it and the method chosen.
    """
    problem._check_alive()
    name, reason = choose_method(problem.operator_kind, problem.size, method)
    cls = solver_class(name)
    wrong = [key for key in options if key not in cls.OPTIONS]
    if wrong:
        raise InputError(wrong[0], f"the solver is {name!r} ({reason}), which takes only "
                                   f"{', '.join(cls.OPTIONS)}; it does not take {', '.join(wrong)}. "
                                   "Pass `method` for the solver these options are meant for")
    solver = cls(problem, name, **options) if cls is ActiveSetSolver else cls(problem, **options)
    solver.method, solver.method_reason = name, reason
    return solver


def _increasing(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=float).ravel()
    if arr.size == 0:
        raise InputError(name, "is empty")
    if not np.all(np.isfinite(arr)):
        raise InputError(name, "must be finite")
    if np.any(np.diff(arr) < 0):
        raise InputError(name, "must be increasing (each increment is warm-started from the last)")
    return arr


def solve_closures(problem: NormalProblem, closures, rotation=(0.0, 0.0), method: str = "auto",
                   **options) -> list[NormalResult]:
    """Displacement control over increasing closures δz, each warm-started (§3.1)."""
    closures = _increasing("closures", closures)
    with make_solver(problem, method, **options) as solver:
        return [solver.solve_closure(c, rotation) for c in closures]


def solve_loads(problem: NormalProblem, loads, moments=(0.0, 0.0), rotation=None,
                method: str = "auto", **options) -> list[NormalResult]:
    """Load control over increasing loads P (same moments or fixed rotation), warm-started."""
    loads = _increasing("loads", loads)
    with make_solver(problem, method, **options) as solver:
        return [solver.solve_load(p, moments, rotation) for p in loads]
