"""Active-set solution of the discrete normal contact problem (§3.1, Eqs. 7–11).

On the current contact set S the flexibility system H_SS p_S = w_S (Eq. 11)
is solved by an inner linear solver (PETSc KSP by default, or the paper's
Gauss–Seidel); then nodes of S in tension (p < 0) are dropped AND nodes
outside S that interpenetrate (gap < 0) are added, until the contact
conditions (Eqs. 7a/7b with p ≥ 0) hold to a stated tolerance.

The rigid-body motion r = (δz, θx, θy) enters through w = C r − gap0
(:mod:`roughcontact.normal.problem`). Each component is either imposed
(displacement control, Eq. 7) or free with its conjugate load imposed (load
control, Eq. 8: P, Mx, My).

Load control is a damped Newton iteration on the free components of r
(:mod:`.rigid_motion`), each step a displacement-controlled active-set solve,
its Hessian C_Sᵀ H_SS⁻¹ C_S from |free| extra inner solves on S.

Failure is never silent: an inner solve that diverges, an active set that
revisits an earlier set (cycling) or exceeds its iteration limit, a line
search that finds no decrease, or too many Newton steps raise
:class:`~roughcontact.errors.ConvergenceError` saying which.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError, InputError
from .problem import NormalProblem
from .result import ContactState
from .rigid_motion import newton_on_motion
from .solver import NormalSolver


@dataclass(frozen=True)
class ActiveSetSettings:
    """Tolerances and limits of the active-set iteration.

    tol
        Contact conditions hold when no node of S carries a tension below
        −tol · max p and no node outside S interpenetrates by more than
        tol · (scale of the imposed interpenetration). 1e-8 sits three
        orders above the inner solver's default relative tolerance (1e-11),
        so round-off in p never flips a node back and forth.
    max_outer
        Active-set iterations allowed before raising.
    min_growth
        Interpenetrating nodes are added all at once unless they outnumber
        the contact set (and this many); then only the deepest ones, as many
        as the set holds, so the set at most doubles per iteration.
    load_tol
        Load control stops when |P − P_imposed| ≤ load_tol · P and the moment
        residuals ≤ load_tol · P · (half-size of the footprint). The default
        equals ``tol``: nodes carrying less than tol · max p may sit on either
        side of the contact boundary, which moves P by up to that much.
    max_newton
        Newton steps on the rigid motion allowed before raising.
    """

    tol: float = 1e-8
    max_outer: int = 200
    min_growth: int = 64
    load_tol: float = 1e-8
    max_newton: int = 50


def _inner_solver(problem: NormalProblem, method: str, rtol: float | None, options: dict | None,
                  prefix: str):
    if method == "ksp":
        from .petsc import KSPSubsolver

        return KSPSubsolver(problem.flexibility, prefix=prefix,
                            rtol=1e-11 if rtol is None else rtol, options=options)
    if method == "gauss-seidel":
        from .gauss_seidel import GaussSeidelSubsolver

        return GaussSeidelSubsolver(problem.flexibility, rtol=1e-11 if rtol is None else rtol)
    raise InputError("method", f"must be 'ksp' or 'gauss-seidel', got {method!r}")


class ActiveSetSolver(NormalSolver):
    """Reusable normal-contact solver on one problem (keeps the inner solver alive).

    Parameters
    ----------
    problem
        The :class:`NormalProblem`.
    method
        ``"ksp"`` (PETSc Krylov, default CG) or ``"gauss-seidel"`` (paper's reference).
    settings
        :class:`ActiveSetSettings`.
    rtol
        Relative tolerance of the inner linear solves (default 1e-11).
    options
        PETSc options for the KSP, set under ``prefix`` (e.g. ``{"ksp_type": "gmres"}``).
    prefix
        PETSc options prefix, default ``"normal_"``.
    """

    #: the keyword options :func:`~.factory.make_solver` passes on
    OPTIONS = ("settings", "rtol", "options", "prefix")

    def __init__(self, problem: NormalProblem, method: str = "ksp",
                 settings: ActiveSetSettings = ActiveSetSettings(), rtol: float | None = None,
                 options: dict | None = None, prefix: str = "normal_"):
        super().__init__(problem)
        self.method = method
        if problem.flexibility.periodic:
            raise InputError("method", f"{method!r} solves displacement-controlled sub-problems, which a "
                                       "periodic operator does not define (its mean mode is free): use 'cg'")
        self.settings = settings
        self.inner = _inner_solver(problem, method, rtol, options, prefix)
        # warm-start columns of the inner solves (full local length): p and the Hessian's
        self.guesses = np.zeros((problem.local_size, 4))

    @property
    def description(self) -> str:
        return f"active set, {self.inner.description}"

    def _release(self) -> None:
        self.inner.destroy()

    def _solve(self, rigid, free, loads):
        if not free:
            return self._displacement(rigid), rigid
        if self.active is not None:
            rigid[free] = self.rigid[free]                   # warm start of the unknown motion
        else:
            rigid[free] = 0.0
            rigid[0] = self.winkler_approach(rigid, loads[0])
        return newton_on_motion(self.problem, rigid, free, free, loads,
                                evaluate=lambda r, needed: (self._displacement(r), r),     # exact
                                stiffness=lambda active: self._hessian(active, free),
                                load_tol=self.settings.load_tol, max_newton=self.settings.max_newton)

    # -- displacement control: the paper's active set -------------------------------
    def _displacement(self, rigid: np.ndarray) -> ContactState:
        """Contact state for an imposed r = (δz, θx, θy), warm-started from the last set."""
        pb, tol = self.problem, self.settings.tol
        n = pb.local_size
        w = pb.interpenetration(rigid)
        w_scale = pb.interpenetration_scale(w)
        if self.active is not None:
            active = self.active.copy()
        else:
            active = w > 0.0                                 # the paper's initial domain
        seen: dict[bytes, int] = {}
        history: list[float] = []
        linear_its = 0
        for outer in range(1, self.settings.max_outer + 1):
            if pb.allsum(active.sum()) == 0:
                if pb.allmax(float((w > 0.0).any())) == 0:
                    # nothing interpenetrates: no contact, a valid state
                    state = ContactState(np.zeros(n), active, -w, outer, linear_its, 0.0, tuple(history))
                    self.active = active.copy()
                    return state
                active = w > 0.0
            self.inner.set_active(active)
            pressure_s, its = self.inner.solve(w[active], self.guesses[active, 3])
            self.guesses[:, 3] = 0.0
            self.guesses[active, 3] = pressure_s
            linear_its += its
            pressure = np.zeros(n)
            pressure[active] = pressure_s
            gap = pb.displacement(pressure) - w             # H p − w (Eq. 7): zero on S, > 0 off S
            p_max = float(pb.allmax(pressure.max(initial=0.0)))
            tension = active & (pressure < -tol * p_max)
            penetration = ~active & (gap < -tol * w_scale)
            residual = self._residual(pressure, gap, active, p_max, w_scale)
            history.append(residual)
            n_changes = pb.allsum(np.array([tension.sum(), penetration.sum()]))
            if n_changes.sum() == 0:
                self.active = active.copy()
                return ContactState(np.where(active, np.maximum(pressure, 0.0), 0.0), active, gap, outer,
                              linear_its, residual, tuple(history))
            active = (active & ~tension) | self._limit_growth(penetration, gap, active, n_changes[1])
            key = self._set_key(active)
            if key in seen:
                raise ConvergenceError(
                    "ACTIVE_SET_CYCLING",
                    f"iteration {outer} returned to the contact set of iteration {seen[key]} "
                    f"({int(pb.allsum(active.sum()))} nodes) with residual {residual:.3e}; "
                    f"the contact conditions cannot be met to tol={tol:g}: loosen the tolerance "
                    "or tighten the inner solver's rtol")
            seen[key] = outer
        raise ConvergenceError(
            "ACTIVE_SET_MAX_ITERATIONS",
            f"{self.settings.max_outer} active-set iterations without meeting tol={tol:g} "
            f"(last residual {history[-1]:.3e}, {int(n_changes[0])} nodes in tension, "
            f"{int(n_changes[1])} interpenetrating); raise ActiveSetSettings.max_outer")

    def _limit_growth(self, penetration, gap, active, n_penetrating) -> np.ndarray:
        """The interpenetrating nodes to add: all of them, unless they outnumber
        the current set, then the most interpenetrating ones, as many as the set
        holds. A warm-start set far too small for a large load step would
        otherwise jump to most of the footprint, where every solve costs the
        most, only to shed it again."""
        pb = self.problem
        n_active = int(pb.allsum(active.sum()))
        cap = max(n_active, self.settings.min_growth)
        if n_penetrating <= cap:
            return penetration
        depth = pb.gather(np.where(penetration, gap, np.inf))
        threshold = np.partition(depth, cap - 1)[cap - 1]
        return penetration & (gap <= threshold)

    def _hessian(self, active, free):
        """C_Sᵀ H_SS⁻¹ C_S for the free components (|free| solves on the set S)."""
        pb = self.problem
        n_free = len(free)
        if pb.allsum(active.sum()) == 0:
            return np.zeros((n_free, n_free)), 0
        self.inner.set_active(active)
        cols = pb.columns_at(active)[:, free]
        basis = np.empty_like(cols)
        its = 0
        for j, k in enumerate(free):
            basis[:, j], itk = self.inner.solve(cols[:, j], self.guesses[active, k])
            its += itk
            self.guesses[:, k] = 0.0
            self.guesses[active, k] = basis[:, j]
        return pb.allsum(cols.T @ basis), its

    def _residual(self, pressure, gap, active, p_max, w_scale) -> float:
        """max of relative tension, interpenetration and equation (gap on S) errors."""
        local = np.array([
            max(0.0, -pressure[active].min(initial=0.0)) / (p_max or 1.0),
            max(0.0, -gap[~active].min(initial=0.0)) / w_scale,
            np.abs(gap[active]).max(initial=0.0) / w_scale,
        ])
        return float(self.problem.allmax(local).max())

    def _set_key(self, active: np.ndarray) -> bytes:
        digest = hashlib.sha1(np.packbits(active).tobytes()).digest()
        return b"".join(self.problem.comm.allgather(digest))
