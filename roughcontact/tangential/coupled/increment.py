"""One increment of the coupled stick/slip problem at constant P (§4.1, Eqs. 14–20, β = 0).

From the converged state at the previous load (traction q⁰, displacement
u⁰ = T q⁰, Eqs. 15–16) to a new tangential load Q (Eq. 19) or a new rigid
translation δ (Eq. 20), the fictitious time of Eq. 14b is discretised by one
backward-Euler step. With the slip increment s_i = Δδ − (T (q − q⁰))_i of
node i (Δδ the change of the rigid translation) the conditions are

- stick: s_i = 0 and |q_i| ≤ f p_i (Eqs. 14a, 20: the stick zone translates rigidly);
- slip:  |q_i| = f p_i and q_i = f p_i s_i / |s_i| (Eq. 14b: the shear along the slip);
- load control: Σ q_i = Q, with Δδ its multiplier.

They are the optimality conditions of the convex program

    min ½ qᵀ T q − qᵀ T q⁰   subject to  |q_i| ≤ f p_i,  Σ q_i = Q,

whose minimiser is unique (T is symmetric positive definite): Kalker's
variational principle of the incremental tangential problem.

Method: an active-set Newton (SQP) iteration on the stick set and on the
traction direction of each slip node, with a Krylov solve of
:class:`~.operator.TangentMat` per unknown right-hand side:

1. on the current sets, K y = −Zᵀ (u − u⁰) + Zᵀ B Δδ, y the traction change
   (both components at stick nodes, the tangential one at slip nodes), and
   Σ (q + Z y) = Q by a 2 × 2 Schur complement in Δδ (three Krylov solves;
   one under displacement control, where Δδ is given);
2. slip nodes are retracted onto their Coulomb circle; stick nodes beyond it
   (|q| > f p (1 + tol)) are projected onto it and slip;
3. u = T q, the slip increments s; slip nodes whose increment opposes their
   traction (s·d < −tol × scale) stick again; η_i = s_i·d_i / (f p_i);
4. stop when no node changed set and the residual — |s| on the stick set,
   |s × d| and max(0, −s·d) on the slip set, over the size of the increment,
   and |Σq − Q| / fP — is at most ``tol``.

Fixing the traction direction of slip nodes and iterating d ← s/|s| instead
(the fixed point of the slip direction) diverges where slip increments are
small next to the displacement a rotated traction causes, which the
curvature term η of Newton's step accounts for.

References: J.J. Kalker, *Three-Dimensional Elastic Bodies in Rolling
Contact*, Kluwer (1990) §2.3, §5.2 (the variational principle, the Cattaneo
shift); E.A.H. Vollebregt, J. Optim. Theory Appl. 87 (1995) 47–67 (the
convex program and its active sets); S. Hüeber, G. Stadler, B.I. Wohlmuth,
SIAM J. Sci. Comput. 30 (2008) 572–596 (active-set Newton for Coulomb
friction in three dimensions).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ...errors import ConvergenceError, InputError
from ...petsc import OptionsScope, solve_checked
from .operator import Basis, ShearOperator, TangentPC, tangent_mat

LOAD, DISPLACEMENT = "load", "displacement"


@dataclass(frozen=True)
class CoupledSettings:
    """Tolerances and limits of a coupled increment.

    tol
        Stick, slip-alignment and equilibrium residuals, relative to the
        increment's displacement scale and to fP. 1e-8 as the normal solvers,
        two orders above the Krylov tolerance.
    max_iterations
        Newton iterations per increment before raising.
    rtol, max_it
        Krylov tolerance and iteration limit (set before ``setFromOptions``).
    """

    tol: float = 1e-8
    max_iterations: int = 60
    rtol: float = 1e-10
    max_it: int = 10000

    def __post_init__(self):
        for name in ("tol", "rtol"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.0 < value < 1.0):
                raise InputError(name, f"must be a number in (0, 1), got {value!r}")
        for name in ("max_iterations", "max_it"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InputError(name, f"must be an integer >= 1, got {value!r}")


@dataclass(frozen=True)
class Increment:
    """A converged increment on this rank's contact nodes."""

    traction: np.ndarray          # q (2, nodes), N
    displacement: np.ndarray      # u = T q (2, local footprint nodes), m
    translation: np.ndarray       # Δδ (2,), m
    slip: np.ndarray              # s (2, nodes), m
    stick: np.ndarray             # stick set (nodes,)
    curvature: np.ndarray         # η (nodes,), 0 on the stick set
    iterations: int
    linear_iterations: int
    residual: float


class IncrementSolver:
    """Newton on the stick and slip sets of one increment, with PETSc Krylov inner solves.

    Parameters
    ----------
    problem
        The normal problem (its communicator and reductions).
    operator
        T on the footprint (:class:`~.operator.ShearOperator`).
    nodes
        Local indices of the contact nodes (p > 0).
    limit
        f p_i on those nodes (the radius of each Coulomb circle), N.
    settings
        :class:`CoupledSettings`.
    prefix, options
        PETSc options prefix of the Krylov solves and options set under it
        for the life of the solver (default CG with the Fourier preconditioner).
    """

    def __init__(self, problem, operator: ShearOperator, nodes: np.ndarray, limit: np.ndarray,
                 settings: CoupledSettings, prefix: str = "coupled_", options: dict | None = None):
        self.problem = problem
        self.operator = operator
        self.nodes = nodes
        self.limit = limit
        self.limit_total = float(problem.allsum(limit.sum()))        # fP (N)
        self.settings = settings
        self.scope = OptionsScope(prefix, options)
        self.ksp = PETSc.KSP().create(problem.comm)
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setType(PETSc.KSP.Type.CG)
        self.ksp.setTolerances(rtol=settings.rtol, atol=0.0, max_it=settings.max_it)
        self.ksp.setInitialGuessNonzero(True)
        self.ksp.setFromOptions()
        self.user_pc = PETSc.Options().hasName(prefix + "pc_type")
        self.guesses: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._mat = None

    # ------------------------------------------------------------------ API
    def solve(self, q0: np.ndarray, u0: np.ndarray, stick: np.ndarray, curvature: np.ndarray,
              control: str, target: np.ndarray) -> Increment:
        """The increment from (q⁰, u⁰ = T q⁰) to the load Q = ``target`` (``control="load"``) or
        to Δδ = ``target`` (``"displacement"``), starting from the sets of the last increment."""
        pb, tol, nodes, rho = self.problem, self.settings.tol, self.nodes, self.limit
        q, u, stick, curvature = q0.copy(), u0.copy(), stick.copy(), curvature.copy()
        translation = np.asarray(target, dtype=float) if control == DISPLACEMENT else np.zeros(2)
        linear = 0
        history: list[float] = []
        for iteration in range(1, self.settings.max_iterations + 1):
            slip = ~stick
            direction = q[:, slip] / rho[slip]
            basis = Basis(nodes, stick, np.stack([-direction[1], direction[0]]), u.shape[1])
            rhs = -basis.reduce(*(u - u0))
            self._set_operator(basis, curvature[slip])
            if control == LOAD:
                step, translation, its = self._load_step(basis, rhs, q, target)
            else:
                step, its = self._solve("r", basis, rhs + self._columns(basis) @ translation)
            linear += its
            gx, gy = basis.fields(step)
            trial = q + np.stack([gx[nodes], gy[nodes]])
            size = np.hypot(trial[0], trial[1])
            entering = stick & (size > rho * (1.0 + tol))
            stick = stick & ~entering
            slip = ~stick
            q = trial
            q[:, slip] *= rho[slip] / np.where(size[slip] > 0.0, size[slip], 1.0)
            u = np.stack(self.operator.product(*self._fields(q, u.shape[1])))
            increment = translation[:, None] - (u - u0)[:, nodes]
            along = np.einsum("ij,ij->j", increment, q) / np.where(rho > 0.0, rho, 1.0)
            across = (increment[1] * q[0] - increment[0] * q[1]) / np.where(rho > 0.0, rho, 1.0)
            scale = float(pb.allmax(max(np.abs(translation).max(), np.abs(u - u0)[:, nodes].max(initial=0.0))))
            leaving = slip & (along < -tol * scale)
            residual = self._residual(increment, along, across, stick, q, control, target, scale)
            history.append(residual)
            changes = int(pb.allsum(np.array([entering.sum() + leaving.sum()], dtype=float))[0])
            stick = stick | leaving
            curvature = np.where(stick, 0.0, np.maximum(along, 0.0) / np.where(rho > 0.0, rho, 1.0))
            if changes == 0 and residual <= tol:
                self._free()
                return Increment(traction=q, displacement=u, translation=translation, slip=increment,
                                 stick=stick, curvature=curvature, iterations=iteration,
                                 linear_iterations=linear, residual=residual)
        self._free()
        raise ConvergenceError(
            "COUPLED_MAX_ITERATIONS",
            f"{self.settings.max_iterations} Newton iterations on the stick and slip sets without meeting "
            f"tol={tol:g} (residuals {', '.join(f'{r:.2e}' for r in history[-4:])}); take smaller load "
            "steps or raise CoupledSettings.max_iterations")

    def destroy(self) -> None:
        self._free()
        self.ksp.destroy()
        self.scope.close()

    # ------------------------------------------------------------ internals
    def _load_step(self, basis: Basis, rhs: np.ndarray, q: np.ndarray, target: np.ndarray):
        """y and Δδ with K y − A Δδ = rhs and Σ (q + Z y) = Q (A = Zᵀ B): a 2 × 2 Schur complement."""
        pb = self.problem
        columns = self._columns(basis)
        free, its = self._solve("r", basis, rhs)
        responses = np.empty_like(columns)
        for k, name in enumerate(("x", "y")):
            responses[:, k], its_k = self._solve(name, basis, columns[:, k])
            its += its_k
        schur = pb.allsum(columns.T @ responses)
        carried = pb.allsum(q.sum(axis=1))
        gap = np.asarray(target, dtype=float) - carried - pb.allsum(columns.T @ free)
        if not np.linalg.cond(schur) < 1e12:
            raise ConvergenceError("COUPLED_NO_STICK", "the stick set no longer fixes the rigid translation "
                                                       "(every node slips): Q is within the grid's resolution "
                                                       "of fP; stop the sweep further below fP")
        translation = np.linalg.solve(schur, gap)
        return free + responses @ translation, translation, its

    def _columns(self, basis: Basis) -> np.ndarray:
        """A = Zᵀ B: the unknowns' share of Σ q along x and y (columns)."""
        ones = np.zeros(basis.local_size)
        ones[basis.stick_nodes] = 1.0
        ones[basis.slip_nodes] = 1.0
        zeros = np.zeros(basis.local_size)
        return np.stack([basis.reduce(ones, zeros), basis.reduce(zeros, ones)], axis=1)

    def _fields(self, q: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
        qx, qy = np.zeros(size), np.zeros(size)
        qx[self.nodes], qy[self.nodes] = q
        return qx, qy

    def _residual(self, increment, along, across, stick, q, control, target, scale) -> float:
        pb = self.problem
        slip = ~stick
        local = np.array([
            np.hypot(*increment[:, stick]).max(initial=0.0) / (scale or 1.0),
            np.abs(across[slip]).max(initial=0.0) / (scale or 1.0),
            max(0.0, -along[slip].min(initial=0.0)) / (scale or 1.0),
        ])
        residual = float(pb.allmax(local).max())
        if control == LOAD:
            carried = pb.allsum(q.sum(axis=1))
            residual = max(residual, float(np.hypot(*(carried - target))) / (self.limit_total or 1.0))
        return residual

    def _set_operator(self, basis: Basis, curvature: np.ndarray) -> None:
        self._free()
        self._mat = tangent_mat(self.operator, basis, curvature)
        self.ksp.setOperators(self._mat)
        if not self.user_pc:
            pc = self.ksp.getPC()
            pc.setType(PETSc.PC.Type.PYTHON)
            pc.setPythonContext(TangentPC(self.operator.flexibility, self.nodes, basis))
        self._x, self._b = self._mat.createVecs()
        self._r = self._b.duplicate()

    def _solve(self, name: str, basis: Basis, rhs: np.ndarray) -> tuple[np.ndarray, int]:
        """K x = rhs, warm-started from the last solution of the same right-hand side."""
        self._b.getArray()[:] = rhs
        previous = self.guesses.get(name)
        self._x.getArray()[:] = basis.reduce(*previous) if previous is not None else 0.0
        its = solve_checked(self.ksp, self._mat, self._b, self._x, self._r,
                            f"the Krylov solve of the stick/slip Newton system ({self._mat.getSize()[0]} unknowns)")
        x = self._x.getArray().copy()
        self.guesses[name] = basis.fields(x)
        return x, its

    def _free(self) -> None:
        self.ksp.reset()
        for name in ("_mat", "_x", "_b", "_r"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
            setattr(self, name, None)
