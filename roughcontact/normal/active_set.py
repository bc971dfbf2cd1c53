"""Active-set solution of the discrete normal contact problem (§3.1, Eqs. 7–11).

On the current contact set S the flexibility system H_SS p_S = w_S (Eq. 11)
is solved by an inner linear solver (PETSc KSP by default, or the paper's
Gauss–Seidel); then nodes of S in tension (p < 0) are dropped AND nodes
outside S that interpenetrate (gap < 0) are added, until the contact
conditions (Eqs. 7a/7b with p ≥ 0) hold to a stated tolerance.

The rigid-body motion r = (δz, θx, θy) enters through w = C r − gap0
(:mod:`roughcontact.normal.problem`). Each component is either imposed
(displacement control, Eq. 7) or free with its conjugate load imposed (load
control, Eq. 8: P, Mx, My). For a fixed S the pressure is linear in r:

    p_S = z0 + Σ_k r_k Z_k,   H_SS z0 = C_fixed r_fixed − gap0,   H_SS Z_k = C_k,

and the free components follow from the |free| × |free| system
C_freeᵀ Z r_free = L_free − C_freeᵀ z0 (symmetric positive definite).

Failure is never silent: an inner solve that diverges, an active set that
revisits an earlier set (cycling) or exceeds its iteration limit raises
:class:`~roughcontact.errors.ConvergenceError` saying which.
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass

import numpy as np

from ..collective import Collective
from ..errors import ConvergenceError, InputError
from ..errors import require_finite as _finite
from .problem import NormalProblem
from .result import NormalResult

DOFS = ("closure", "rotation_x", "rotation_y")


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
    """

    tol: float = 1e-8
    max_outer: int = 200


def _inner_solver(problem: NormalProblem, method: str, rtol: float | None, options: dict | None,
                  prefix: str):
    if method == "ksp":
        from .petsc import KSPSubsolver

        return KSPSubsolver(problem.operator, problem.start, prefix=prefix,
                            rtol=1e-11 if rtol is None else rtol, options=options)
    if method == "gauss-seidel":
        from .gauss_seidel import GaussSeidelSubsolver

        return GaussSeidelSubsolver(problem.operator, problem.start, problem.comm,
                                    rtol=1e-11 if rtol is None else rtol)
    raise InputError("method", f"must be 'ksp' or 'gauss-seidel', got {method!r}")


class ActiveSetSolver(Collective):
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

    def __init__(self, problem: NormalProblem, method: str = "ksp",
                 settings: ActiveSetSettings = ActiveSetSettings(), rtol: float | None = None,
                 options: dict | None = None, prefix: str = "normal_"):
        self.problem = problem
        self.settings = settings
        self.method = method
        self.inner = _inner_solver(problem, method, rtol, options, prefix)
        n = problem.local_size
        # warm-start state: last contact set, last solution columns (full local length)
        self.active: np.ndarray | None = None
        self.guesses = np.zeros((n, 4))
        self.rigid = np.zeros(3)

    def destroy(self) -> None:
        self.inner.destroy()

    # ------------------------------------------------------------------ API
    def warm_start(self, result: NormalResult) -> None:
        """Start the next solve from ``result`` (a solution of the same problem):
        its contact set and rigid motion, e.g. a corrective solve from the actual one."""
        pb = self.problem
        self.active = result.contact[pb.topography.footprint][pb.start:pb.stop].copy()
        self.rigid = np.array([result.closure, *result.rotation], dtype=float)

    def solve_closure(self, closure: float, rotation: tuple[float, float] = (0.0, 0.0)) -> NormalResult:
        """Displacement control: impose δz and (θx, θy) (Eq. 7)."""
        closure = _finite("closure", closure)
        rotation = tuple(_finite(f"rotation[{k}]", v) for k, v in enumerate(_pair("rotation", rotation)))
        return self._solve(np.array([closure, *rotation]), fixed=(0, 1, 2), loads=np.zeros(3),
                           control="displacement")

    def solve_load(self, load: float, moments: tuple[float, float] = (0.0, 0.0),
                   rotation: tuple[float, float] | None = None) -> NormalResult:
        """Load control: impose P and (Mx, My) about the footprint centroid (Eq. 8).

        The solver finds δz and, unless ``rotation`` fixes them, θx, θy; with a
        fixed rotation the moments are outputs and ``moments`` must be left 0.
        """
        load = _finite("load", load)
        if load < 0.0:
            raise InputError("load", f"must be >= 0 (a compressive normal load), got {load!r}")
        mx, my = (_finite(f"moments[{k}]", v) for k, v in enumerate(_pair("moments", moments)))
        if rotation is None:
            fixed, rigid = (), np.zeros(3)
        else:
            if mx != 0.0 or my != 0.0:
                raise InputError("moments", "cannot impose moments with a fixed rotation; "
                                            "leave rotation=None to let the solver find it")
            rigid = np.array([0.0, *(_finite(f"rotation[{k}]", v)
                                     for k, v in enumerate(_pair("rotation", rotation)))])
            fixed = (1, 2)
        if load > 0.0 and rotation is None:
            point = np.array([my, mx]) / load
            if not self.problem.load_point_inside(point):
                raise InputError("moments", f"the load point (x, y) = ({point[0] + self.problem.centroid[0]:.6g}, "
                                            f"{point[1] + self.problem.centroid[1]:.6g}) m lies outside the "
                                            "footprint: no compressive pressure can balance it")
        return self._solve(rigid, fixed=fixed, loads=np.array([load, -mx, -my]), control="load")

    # ------------------------------------------------------------ internals
    def _solve(self, rigid: np.ndarray, fixed: tuple[int, ...], loads: np.ndarray,
               control: str) -> NormalResult:
        t0 = time.perf_counter()
        pb, tol = self.problem, self.settings.tol
        free = [k for k in range(3) if k not in fixed]
        n = pb.local_size
        rigid = rigid.astype(float).copy()
        if free:
            rigid[free] = self.rigid[free]   # warm start of the unknown motion

        if control == "load" and loads[0] == 0.0:
            return self._finish(np.zeros(n), np.zeros(n, bool), rigid, 0, 0, 0.0, (), control, t0,
                                -pb.interpenetration(rigid))

        active = self._initial_active(rigid, free, loads)
        seen: dict[bytes, int] = {}
        history: list[float] = []
        linear_its = 0
        for outer in range(1, self.settings.max_outer + 1):
            if pb.allsum(active.sum()) == 0:
                # nothing in contact: a valid state when nothing interpenetrates
                w = pb.interpenetration(rigid)
                if free:        # a positive load needs a contact set
                    active = self._enlarge(active, rigid)
                elif pb.allmax(float((w > 0.0).any())) > 0:
                    active = w > 0.0
                else:
                    return self._finish(np.zeros(n), active, rigid, outer, linear_its, 0.0,
                                        tuple(history), control, t0, -w)
            self.inner.set_active(active)
            rigid, pressure, its = self._solve_on_set(active, rigid, free, fixed, loads)
            if pressure is None:       # singular load system: enlarge the set and retry
                active = self._enlarge(active, rigid)
                continue
            linear_its += its
            gap = self._gap(pressure, rigid, active)
            p_max = float(pb.allmax(pressure.max(initial=0.0)))
            w_scale = self._w_scale(rigid)
            tension = active & (pressure < -tol * p_max)
            penetration = ~active & (gap < -tol * w_scale)
            residual = self._residual(pressure, gap, active, p_max, w_scale)
            history.append(residual)
            n_changes = pb.allsum(np.array([tension.sum(), penetration.sum()]))
            if n_changes.sum() == 0:
                pressure = np.where(active, np.maximum(pressure, 0.0), 0.0)
                return self._finish(pressure, active, rigid, outer, linear_its, residual,
                                    tuple(history), control, t0, gap)
            active = (active & ~tension) | penetration
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

    def _initial_active(self, rigid, free, loads) -> np.ndarray:
        pb = self.problem
        if self.active is not None:
            return self.active.copy()
        if not free:
            return pb.interpenetration(rigid) > 0.0      # the paper's initial domain
        # load control, cold start: the nodes nearest to first touch
        k = min(pb.size, max(3 * len(free), 4))
        threshold = np.partition(pb.gather(pb.gap0), k - 1)[k - 1]
        return pb.gap0 <= threshold

    def _solve_on_set(self, active, rigid, free, fixed, loads):
        """p on the set S, and the free components of r; (rigid, None, its) if singular."""
        pb = self.problem
        cols = pb.columns[active]
        imposed = rigid.copy()
        imposed[free] = 0.0
        z0, its = self.inner.solve(pb.interpenetration(imposed)[active], self.guesses[active, 3])
        self.guesses[:, 3] = 0.0
        self.guesses[active, 3] = z0
        pressure_s = z0
        if free:
            basis = []
            for k in free:
                zk, itk = self.inner.solve(cols[:, k], self.guesses[active, k])
                its += itk
                self.guesses[:, k] = 0.0
                self.guesses[active, k] = zk
                basis.append(zk)
            basis = np.stack(basis, axis=1)
            system = pb.allsum(cols[:, free].T @ basis)
            rhs = loads[free] - pb.allsum(cols[:, free].T @ z0)
            if np.linalg.cond(system) > 1e12:
                return rigid, None, its
            rigid = rigid.copy()
            rigid[free] = np.linalg.solve(system, rhs)
            pressure_s = z0 + basis @ rigid[free]
        pressure = np.zeros(pb.local_size)
        pressure[active] = pressure_s
        return rigid, pressure, its

    def _enlarge(self, active, rigid) -> np.ndarray:
        """Add the nodes closest to contact (largest w) outside S, doubling |S|."""
        pb = self.problem
        w = np.where(active, -np.inf, pb.interpenetration(rigid))
        k = max(3, int(pb.allsum(active.sum())))
        values = pb.gather(w)
        k = min(k, int(np.isfinite(values).sum()))
        if k == 0:
            raise ConvergenceError("ACTIVE_SET_SINGULAR", "the load system is singular on the whole footprint")
        threshold = np.partition(values, values.size - k)[values.size - k]
        return active | (w >= threshold)

    def _gap(self, pressure: np.ndarray, rigid: np.ndarray, active: np.ndarray) -> np.ndarray:
        """Deformed gap g = H p − w (Eq. 7: zero on S, positive outside); p is zero off S."""
        from ..elastic.petsc import apply_on_columns

        pb = self.problem
        return apply_on_columns(pb.operator, pressure, active, pb.start) - pb.interpenetration(rigid)

    def _w_scale(self, rigid) -> float:
        w = self.problem.interpenetration(rigid)
        scale = float(self.problem.allmax(np.abs(w).max(initial=0.0)))
        return max(scale, self.problem.height_range) or 1.0

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

    def _finish(self, pressure, active, rigid, outer, linear_its, residual, history, control, t0,
                gap) -> NormalResult:
        pb = self.problem
        self.active = active.copy()
        self.rigid = rigid.copy()
        forces = pb.gather(pressure)
        contact = pb.gather(active)
        gaps = pb.gather(np.where(active, 0.0, gap))
        moments = pb.allsum(np.array([pressure.sum(), pressure @ pb.y, pressure @ pb.x]))
        load = float(moments[0])
        s = pb.topography.spacing
        if load > 0.0:
            centroid = (pb.centroid[0] + moments[2] / load, pb.centroid[1] + moments[1] / load)
        else:
            centroid = (float("nan"), float("nan"))
        n_contact = int(contact.sum())
        return NormalResult(
            force=pb.to_field(forces), pressure=pb.to_field(forces / s**2),
            contact=pb.to_field(contact, False), gap=pb.to_field(gaps, np.nan),
            load=load, moments=(float(moments[1]), float(moments[2])),
            centroid=(float(centroid[0]), float(centroid[1])),
            reference_point=(float(pb.centroid[0]), float(pb.centroid[1])),
            closure=float(rigid[0]), rotation=(float(rigid[1]), float(rigid[2])),
            contact_area=n_contact * s**2, nominal_area=pb.size * s**2,
            outer_iterations=outer, linear_iterations=int(linear_its), residual=float(residual),
            elapsed=time.perf_counter() - t0, solver=self.inner.description, control=control,
            no_contact=n_contact == 0, full_contact=n_contact == pb.size,
            residual_history=tuple(history))


def _pair(name: str, value) -> tuple:
    try:
        a, b = value
    except (TypeError, ValueError):
        raise InputError(name, f"must be a pair (x, y), got {value!r}") from None
    return a, b


def _increasing(name: str, values) -> np.ndarray:
    arr = np.asarray(values, dtype=float).ravel()
    if arr.size == 0:
        raise InputError(name, "is empty")
    if not np.all(np.isfinite(arr)):
        raise InputError(name, "must be finite")
    if np.any(np.diff(arr) < 0):
        raise InputError(name, "must be increasing (each increment is warm-started from the last)")
    return arr


def solve_closures(problem: NormalProblem, closures, rotation=(0.0, 0.0), method: str = "ksp",
                   **kwargs) -> list[NormalResult]:
    """Displacement control over increasing closures δz, each warm-started (§3.1)."""
    closures = _increasing("closures", closures)
    with ActiveSetSolver(problem, method, **kwargs) as solver:
        return [solver.solve_closure(c, rotation) for c in closures]


def solve_loads(problem: NormalProblem, loads, moments=(0.0, 0.0), rotation=None,
                method: str = "ksp", **kwargs) -> list[NormalResult]:
    """Load control over increasing loads P (same moments or fixed rotation), warm-started."""
    loads = _increasing("loads", loads)
    with ActiveSetSolver(problem, method, **kwargs) as solver:
        return [solver.solve_load(p, moments, rotation) for p in loads]
