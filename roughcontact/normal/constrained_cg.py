"""Bound-constrained conjugate gradients: the contact set is updated inside the Krylov iteration.

The discrete normal contact problem (Eqs. 7–11) is the quadratic program

    min ½ pᵀ H p − pᵀ w_fixed    subject to   p ≥ 0,   C_freeᵀ p = L_free,

where w_fixed = C_fixed r_fixed − gap0 collects the imposed components of
the rigid motion r = (δz, θx, θy), C = [1, −y, −x] (Eq. 8) and L_free the
loads conjugate to the free components. Its Lagrange multipliers are the
free components of r, and its optimality conditions are exactly the contact
conditions: the deformed gap g = H p − w_fixed − C_free r_free is zero where
p > 0 and non-negative where p = 0 (Eqs. 7a/7b). Displacement control has
no constraint, load control with a fixed rotation one (ΣP, Polonsky & Keer's
case), load control with free rotation three (P, Mx, My).

The iteration is Polonsky & Keer's constrained conjugate gradient, with a
preconditioner and with the load constraints generalised from ΣP to Cᵀp:

1. on the current contact set S = {p > 0}, the multipliers r_free are the
   least-squares fit of the gradient H p − w_fixed by the columns C_free on
   S, and the gap g is the remainder;
2. the search direction is the preconditioned, projected gap
   z = Π M Π g (Π: orthogonal projection on S onto Cᵀ z = 0; M: the Fourier
   preconditioner of the contact set, :mod:`~roughcontact.operators.preconditioner`),
   made conjugate to the previous one unless S changed;
3. the step α = gᵀz / dᵀHd (one FFT product per iteration), then
   p ← max(p − α d, 0); nodes outside S that interpenetrate (g < 0) enter
   with the force that closes their gap alone, −g_i / H_ii, and the
   conjugacy restarts;
4. the loads are restored exactly: p ← p · P/Σp for one constraint; for
   three, p_i ← p_i (C λ)_i with the 3 × 3 system Cᵀ diag(p) C λ = L.

It stops when the residual of the contact conditions,
max(|g| on S, max(−g) off S) / (scale of w), is at most ``tol`` (the same
measure and default as the active-set solver), and raises
:class:`~roughcontact.errors.ConvergenceError` when it cannot: the
iteration limit, a loss of positive curvature (dᵀHd ≤ 0), or a load that
the footprint cannot carry with p ≥ 0.

References: I.A. Polonsky, L.M. Keer, Wear 231 (1999) 206–219;
E.A.H. Vollebregt, J. Comput. Phys. 257 (2014) 333–351 (preconditioning the
contact set with FFTs); N.I.M. Gould, M.E. Hribar, J. Nocedal, SIAM J. Sci.
Comput. 23 (2001) 1376–1395 (projected preconditioned CG for equality
constraints).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConvergenceError, InputError
from .nested import COARSE_TOL, NestedStart
from .problem import NormalProblem
from .solver import ContactState, NormalSolver

PRECONDITIONERS = ("fourier", "none")


@dataclass(frozen=True)
class CGSettings:
    """Tolerances and limits of the bound-constrained CG.

    tol
        The contact conditions hold when |g| ≤ tol · (scale of w) on S and
        g ≥ −tol · (scale of w) off S; the loads hold to round-off.
    max_iterations
        CG iterations allowed before raising.
    preconditioner
        ``"fourier"`` (default) or ``"none"`` (Polonsky & Keer's original).
    refresh
        Recompute H p from scratch every this many iterations without a change
        of S (otherwise it is updated by the step, which accumulates round-off).
    restart
        Restart the conjugate directions when more than this fraction of S
        left or entered it in one iteration. Restarting on every change turns
        the tail of the iteration, where a few boundary nodes flip each time,
        into preconditioned steepest descent; never restarting loses
        conjugacy when S changes a lot. 0.05 took the fewest iterations on
        self-affine surfaces from 256² to 1024² (scripts/bench_normal_large.py).
    """

    tol: float = 1e-8
    max_iterations: int = 5000
    preconditioner: str = "fourier"
    refresh: int = 50
    restart: float = 0.05

    def __post_init__(self):
        if self.preconditioner not in PRECONDITIONERS:
            raise InputError("preconditioner", f"must be one of {', '.join(PRECONDITIONERS)}, "
                                               f"got {self.preconditioner!r}")


class ConstrainedCGSolver(NormalSolver):
    """Normal contact by bound-constrained, preconditioned conjugate gradients.

    Parameters
    ----------
    problem
        The :class:`NormalProblem` (any operator; FFT operators make each
        iteration O(N log N)).
    settings
        :class:`CGSettings`.
    nested
        Start cold solves from the solution on the grid of spacing 2s
        (:mod:`.nested`), when the grid is fine enough for it to pay off.
    """

    def __init__(self, problem: NormalProblem, settings: CGSettings = CGSettings(), nested: bool = True):
        super().__init__(problem)
        if not isinstance(settings, CGSettings):
            raise InputError("settings", f"must be a CGSettings, got {type(settings).__name__}")
        self.settings = settings
        if settings.preconditioner == "fourier":
            problem.flexibility.preconditioner   # built now, collectively, not inside a solve
        coarse_settings = replace(settings, tol=max(settings.tol, COARSE_TOL))
        self.nested = NestedStart(problem, lambda coarse: ConstrainedCGSolver(coarse, coarse_settings)) \
            if nested and NestedStart.applies(problem) else None

    @property
    def description(self) -> str:
        s = self.settings
        return f"bound-constrained CG, {s.preconditioner} preconditioner (tol={s.tol:g})"

    def _release(self) -> None:
        if self.nested is not None:
            self.nested.destroy()

    # ---------------------------------------------------------------- solve
    def _solve(self, rigid, free, loads):
        pb, settings = self.problem, self.settings
        rigid = rigid.copy()
        rigid[free] = 0.0
        w = pb.interpenetration(rigid)                 # w_fixed: free components of r left out
        constraints = _Constraints(pb, free, loads)
        w_scale = max(float(pb.allmax(np.abs(w).max(initial=0.0))), pb.height_range) or 1.0
        forces = self._start(rigid, free, loads, w, 1.0 / pb.flexibility.diagonal)
        if free:
            support = np.flatnonzero(forces > 0.0)
            forces[support] = constraints.restore(forces[support], support)[0]
        displacement = pb.displacement(forces)
        direction = np.zeros_like(forces)              # zero outside the free set
        previous = None                                # gᵀz of the last iteration, None: restart
        working = np.zeros(0, dtype=np.intp)           # the free set of the last iteration
        history: list[float] = []
        since_refresh = 0
        for iteration in range(1, settings.max_iterations + 1):
            contact = np.flatnonzero(forces > 0.0)
            gap = displacement - w
            multipliers = constraints.fit(gap[contact], contact)
            constraints.subtract(gap, multipliers)     # the deformed gap, zero on S at the solution
            # max(|g| on S, max(−g) off S): −g ≤ |g| on S, so the minimum may run over all nodes
            residual = float(pb.allmax(max(np.abs(gap[contact]).max(initial=0.0), -gap.min(initial=0.0)))) / w_scale
            history.append(residual)
            if residual <= settings.tol:
                if since_refresh == 0:
                    return self._state(forces, gap, iteration, residual, history), \
                        self._rigid(rigid, free, multipliers)
                # confirm on an exact H p (the updated one carries the steps' round-off)
                displacement = pb.displacement(forces)
                since_refresh = 0
                continue
            # the free set F: nodes in contact, and nodes off it that interpenetrate (g < 0), which the
            # step loads along with the others; the rest stay at p = 0
            last, working = working, np.union1d(contact, np.flatnonzero(gap < 0.0))
            counts = pb.allsum(np.array([np.setxor1d(last, working, assume_unique=True).size, working.size]))
            if counts[0] > settings.restart * counts[1]:
                previous = None
            g = gap[working]
            z = constraints.project(self._precondition(g, working), working)
            gz = float(pb.allsum(g @ z))
            step_direction = z if previous is None or gz <= 0.0 else \
                constraints.project(z + (gz / previous) * direction[working], working)
            previous = gz
            direction[last] = 0.0
            direction[working] = step_direction
            product = pb.displacement(direction)
            curvature = float(pb.allsum(step_direction @ product[working]))
            if not curvature > 0.0:
                raise ConvergenceError(
                    "CG_INDEFINITE", f"iteration {iteration}: dᵀHd = {curvature:.3e} <= 0 on a set of "
                                     f"{int(counts[1])} nodes; the operator is not positive definite there")
            step = gz / curvature
            trial = forces[working] - step * step_direction
            leaving = trial < 0.0
            trial[leaving] = 0.0
            cut = bool(pb.allmax(float(leaving.any())) > 0.0)
            scale = 1.0
            if free:
                # a step along d keeps Cᵀp = L (d lies in the null space of C_Fᵀ): restoring the
                # loads then only removes round-off, unless nodes were cut at p = 0
                trial, scale = constraints.restore(trial, working)
            forces[working] = trial
            since_refresh += 1
            if cut or scale is None or since_refresh >= settings.refresh:
                displacement = pb.displacement(forces)
                since_refresh = 0
            else:
                displacement -= step * product
                if scale != 1.0:
                    displacement *= scale              # H is linear: a uniform rescaling is exact
        raise ConvergenceError(
            "CG_MAX_ITERATIONS",
            f"{settings.max_iterations} bound-constrained CG iterations without meeting tol={settings.tol:g} "
            f"(last residual {history[-1]:.3e}); raise CGSettings.max_iterations or loosen tol")

    # ------------------------------------------------------------- helpers
    def _start(self, rigid, free, loads, w, stiffness) -> np.ndarray:
        """Initial forces: the last solution (warm start), a coarse grid's, or independent punches."""
        pb = self.problem
        self.coarse_iterations = 0
        if self.forces is not None and pb.allsum(self.forces.sum()) > 0.0:
            return self.forces.copy()
        if self.nested is not None:
            start = self.nested.start(rigid, free, loads)
            if start is not None and pb.allsum(start[0].sum()) > 0.0:
                self.coarse_iterations = self.nested.iterations
                return start[0]
        if free:
            rigid = rigid.copy()
            rigid[0] = self.winkler_approach(rigid, loads[0])
            overlap = pb.interpenetration(rigid)
        else:
            overlap = w
        return np.maximum(overlap, 0.0) * stiffness

    def _precondition(self, g: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        if self.settings.preconditioner == "none":
            return g.copy()
        return self.problem.flexibility.precondition_nodes(g, nodes)

    def _rigid(self, rigid, free, multipliers) -> np.ndarray:
        out = rigid.copy()
        out[free] = multipliers
        return out

    def _state(self, forces, gap, iterations, residual, history) -> ContactState:
        contact = forces > 0.0
        gap[contact] = 0.0
        return ContactState(forces, contact, gap, 1, iterations, residual, tuple(history))


class _Constraints:
    """The load constraints C_freeᵀ p = L_free and their multipliers r_free (Eq. 8).

    Columns of C: 1 (δz, P), −y (θx, Mx), −x (θy, My); all operations are on
    node subsets (the contact or free set) given by their indices.
    """

    def __init__(self, problem: NormalProblem, free: list[int], loads: np.ndarray):
        self.problem = problem
        self.free = free
        self.columns = problem.columns[:, free]
        self.target = loads[free]
        self.k = len(free)

    def fit(self, values: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """Least-squares r with C r ≈ values on ``nodes`` (for one constraint: their mean)."""
        k = self.k
        if k == 0:
            return np.zeros(0)
        if k == 1:
            sums = self.problem.allsum(np.array([values.sum(), values.size]))
            return np.array([sums[0] / sums[1] if sums[1] else 0.0])
        c = self.columns[nodes]
        sums = self.problem.allsum(np.concatenate([(c.T @ c).ravel(), c.T @ values]))
        return _solve_small(sums[:k * k].reshape(k, k), sums[k * k:])

    def subtract(self, gap: np.ndarray, multipliers: np.ndarray) -> None:
        """gap −= C r on every node, in place (the first column, δz's, is all ones)."""
        if self.k:
            gap -= multipliers[0]
        for column, value in zip(self.columns.T[1:], multipliers[1:]):
            gap -= value * column

    def project(self, values: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """Remove from ``values`` (on ``nodes``) their fit by C: then Cᵀ values = 0, the loads stay put."""
        if self.k == 0:
            return values
        r = self.fit(values, nodes)
        return values - (r[0] if self.k == 1 else self.columns[nodes] @ r)

    def restore(self, forces: np.ndarray, nodes: np.ndarray):
        """Forces on ``nodes`` rescaled to Cᵀ p = L exactly, and the scale: a number for one
        constraint (exact to apply to H p too), None for three (p_i (C λ)_i, Cᵀ diag(p) C λ = L)."""
        pb, k = self.problem, self.k
        if k == 1:
            total = float(pb.allsum(forces.sum()))
            if not total > 0.0:
                raise ConvergenceError("CG_NO_CONTACT", "every force vanished during the iteration; "
                                                        "the load cannot be restored")
            scale = self.target[0] / total
            return forces * scale, (1.0 if abs(scale - 1.0) <= 1e-15 else scale)
        c = self.columns[nodes]
        for _ in range(8):
            normal = pb.allsum((c.T @ (c * forces[:, None])).ravel()).reshape(k, k)
            factor = c @ _solve_small(normal, self.target)
            loaded = forces > 0.0
            if float(pb.allmin(factor[loaded].min(initial=np.inf))) >= 0.0:
                change = float(pb.allmax(np.abs(factor[loaded] - 1.0).max(initial=0.0)))
                return forces * factor, (1.0 if change <= 1e-13 else None)
            forces = forces * np.maximum(factor, 0.0)  # nodes the moments cannot load leave, then refit
        raise ConvergenceError("CG_LOAD_POINT", "the imposed moments cannot be carried by compressive forces "
                                                "on the current contact set")


def _solve_small(matrix: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Solve a k × k system (k ≤ 3), least squares if it is singular (too few nodes to fix a rotation)."""
    solution, *_ = np.linalg.lstsq(matrix, right, rcond=1e-12)
    return solution
