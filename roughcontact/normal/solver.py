"""What every normal-contact solver shares: the controls of Eqs. 7–8, cold starts, the result.

A solver imposes the rigid-body motion r = (δz, θx, θy) or its conjugate
loads (P, Mx, My) (Eqs. 7–8): :meth:`NormalSolver.solve_closure` fixes all of
r (displacement control); :meth:`NormalSolver.solve_load` imposes P and
either the moments (θ free) or the rotation (moments are outputs). Methods
differ only in how they find the contact state, :meth:`NormalSolver._solve`:

- ``"ksp"`` / ``"gauss-seidel"``: the paper's active set (§3.1) with Krylov or
  Gauss–Seidel inner solves, load control by Newton on r
  (:mod:`.active_set`);
- ``"cg"``: bound-constrained conjugate gradients that update the contact
  set inside the iteration and impose the loads as linear constraints
  (:mod:`.constrained_cg`).

:func:`~.factory.make_solver` builds one by name.
"""
from __future__ import annotations

import time

import numpy as np

from ..checks import require_finite as _finite
from ..collective import Collective
from ..errors import InputError
from ..threads import single_blas_thread
from .fields import gather_result
from .problem import NormalProblem
from .result import ContactState, NormalResult


class NormalSolver(Collective):
    """Base of the normal solvers: controls, input checks, warm starts, results.

    Subclasses implement :meth:`_solve` and :attr:`description`.
    """

    def __init__(self, problem: NormalProblem):
        problem._check_alive()
        self.problem = problem
        # warm-start state: last contact set, forces and rigid motion on this rank
        self.active: np.ndarray | None = None
        self.forces: np.ndarray | None = None
        self.rigid = np.zeros(3)

    description = ""
    method = ""
    method_reason = "given"

    # ------------------------------------------------------------------ API
    def warm_start(self, result: NormalResult) -> None:
        """Start the next solve from ``result`` (a solution of the same problem):
        its contact set, forces and rigid motion, e.g. a corrective solve from the actual one."""
        self._check_alive()
        layout = self.problem.flexibility.layout
        (r0, r1), mask = layout.rows, layout.local_mask
        if result.distributed:
            if tuple(result.rows) != tuple(layout.rows) or result.force.shape != mask.shape:
                raise InputError("result", f"holds grid rows {result.rows[0]}:{result.rows[1]}, this rank "
                                           f"owns {r0}:{r1}: it was solved on another problem or communicator")
            force, contact = result.force, result.contact
        else:                                          # this rank's rows of the whole fields
            if result.force.shape != layout.shape:     # whole fields: the same answer on every rank
                raise InputError("result", f"holds a {result.force.shape[0]} x {result.force.shape[1]} grid, "
                                           f"this problem's is {layout.shape[0]} x {layout.shape[1]}: it was "
                                           "solved on another problem")
            force, contact = result.force[r0:r1], result.contact[r0:r1]
        self.start_from(force[mask], np.array([result.closure, *result.rotation]), contact[mask])

    def start_from(self, forces: np.ndarray, rigid: np.ndarray, active: np.ndarray | None = None) -> None:
        """Start the next solve from nodal forces on this rank's nodes (cut at 0), the rigid
        motion (δz, θx, θy) and the contact set (by default where the forces are positive),
        e.g. an extrapolation of earlier solutions."""
        self._check_alive()
        self.forces = np.maximum(np.asarray(forces, dtype=float), 0.0)
        self.active = self.forces > 0.0 if active is None else np.array(active, dtype=bool)
        self.rigid = np.array(rigid, dtype=float)

    def solve_closure(self, closure: float, rotation: tuple[float, float] = (0.0, 0.0),
                      gather: bool = True) -> NormalResult:
        """Displacement control: impose δz and (θx, θy) (Eq. 7).

        ``gather``: the result's fields are the whole grid on every rank (True), or only each
        rank's own grid rows (False: no rank holds N values; :mod:`.fields` gathers or writes them).
        """
        self._check_alive()
        closure = _finite("closure", closure)
        rotation = tuple(_finite(f"rotation[{k}]", v) for k, v in enumerate(_pair("rotation", rotation)))
        return self._run(np.array([closure, *rotation]), fixed=(0, 1, 2), loads=np.zeros(3),
                         control="displacement", gather=gather)

    def solve_load(self, load: float, moments: tuple[float, float] = (0.0, 0.0),
                   rotation: tuple[float, float] | None = None, gather: bool = True) -> NormalResult:
        """Load control: impose P and (Mx, My) about the footprint centroid (Eq. 8).

        The solver finds δz and, unless ``rotation`` fixes them, θx, θy; with a
        fixed rotation the moments are outputs and ``moments`` must be left 0.
        ``gather`` as in :meth:`solve_closure`.
        """
        self._check_alive()
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
        return self._run(rigid, fixed=fixed, loads=np.array([load, -mx, -my]), control="load", gather=gather)

    # ------------------------------------------------------------ internals
    def _run(self, rigid: np.ndarray, fixed: tuple[int, ...], loads: np.ndarray, control: str,
             gather: bool) -> NormalResult:
        if not isinstance(gather, (bool, np.bool_)):
            raise InputError("gather", f"must be True or False, got {gather!r}")
        with single_blas_thread():                     # BLAS threads would spin beside the FFT's
            return self._run_limited(rigid, fixed, loads, control, bool(gather))

    def _run_limited(self, rigid, fixed, loads, control: str, gather: bool) -> NormalResult:
        t0 = time.perf_counter()
        self.problem._check_alive()
        free = [k for k in range(3) if k not in fixed]
        if self.problem.flexibility.periodic and (free != [0] or rigid[1] != 0.0 or rigid[2] != 0.0):
            raise InputError("control", "a periodic operator fixes the mean displacement only through the load "
                                        "and has no footprint to tilt: use solve_load(P, rotation=(0, 0))")
        rigid = rigid.astype(float).copy()
        if free and loads[0] == 0.0:
            # no load: the bodies at first touch (free rotations zero, fixed ones kept),
            # the largest approach with nothing interpenetrating
            pb = self.problem
            rigid[free] = 0.0
            rigid[0] = -float(pb.allmax(pb.interpenetration(rigid).max(initial=-np.inf)))
            n = pb.local_size
            state = ContactState(np.zeros(n), np.zeros(n, bool), -pb.interpenetration(rigid), 0, 0, 0.0, ())
        else:
            state, rigid = self._solve(rigid, free, loads)
        return self._finish(state, rigid, control, t0, gather)

    def _solve(self, rigid: np.ndarray, free: list[int], loads: np.ndarray) -> tuple[ContactState, np.ndarray]:
        """The contact state for r with the components ``free`` found from ``loads[free]``."""
        raise NotImplementedError  # pragma: no cover - overridden

    def winkler_approach(self, rigid: np.ndarray, load: float) -> float:
        """Load control, cold start: the approach of independent punches.

        Each node alone is a spring of stiffness 1/H_ii; δ solves
        Σ (δ − b_i)⁺ / H_ii = P, with b_i the initial gap under the imposed
        rotation. Interaction between nodes only softens the surface, so this
        underestimates δz and the iteration continues from a small, cheap
        contact set.
        """
        pb = self.problem
        stiffness = 1.0 / pb.flexibility.diagonal
        imposed = rigid.copy()
        imposed[0] = 0.0
        gaps = np.sort(pb.gather(-pb.interpenetration(imposed)), kind="stable")   # gap at zero approach
        approach = (load / stiffness + np.cumsum(gaps)) / np.arange(1, gaps.size + 1)  # if m+1 nodes touch
        upper = np.append(gaps[1:], np.inf)
        m = int(np.argmax((approach >= gaps) & (approach <= upper)))
        return float(approach[m])

    def _finish(self, state: ContactState, rigid, control, t0, gather: bool = True) -> NormalResult:
        pb = self.problem
        pressure, active, gap = state.pressure, state.active, state.gap
        self.active = active.copy()
        self.forces = pressure.copy()
        self.rigid = rigid.copy()
        s = pb.topography.spacing
        gaps = np.where(active, 0.0, gap)
        rows = tuple(pb.flexibility.layout.rows)
        force, contact, gaps = pb.to_rows(pressure), pb.to_rows(active, False), pb.to_rows(gaps, np.nan)
        n_contact = int(pb.allsum(np.count_nonzero(active)))
        moments = pb.allsum(pb.moments(pressure))
        load = float(moments[0])
        if load > 0.0:
            centroid = (pb.centroid[0] + moments[2] / load, pb.centroid[1] + moments[1] / load)
        else:
            centroid = (float("nan"), float("nan"))
        result = NormalResult(
            force=force, pressure=force / s**2, contact=contact, gap=gaps,
            load=load, moments=(float(moments[1]), float(moments[2])),
            centroid=(float(centroid[0]), float(centroid[1])),
            reference_point=(float(pb.centroid[0]), float(pb.centroid[1])),
            closure=float(rigid[0]), rotation=(float(rigid[1]), float(rigid[2])),
            contact_area=n_contact * s**2, nominal_area=pb.size * s**2,
            outer_iterations=state.outer, linear_iterations=int(state.linear),
            residual=float(state.residual), elapsed=time.perf_counter() - t0,
            solver=self.description, control=control, operator=pb.operator_kind, method=self.method,
            choice=f"operator {pb.operator_kind} ({pb.operator_reason}); method {self.method} ({self.method_reason})",
            coarse_iterations=int(getattr(self, "coarse_iterations", 0)),
            no_contact=n_contact == 0, full_contact=n_contact == pb.size,
            residual_history=tuple(state.history), rows=rows, contact_nodes=n_contact)
        # whole fields: each rank's rows received in place (N values per field on every rank, no more)
        return gather_result(result, pb) if gather else result



def _pair(name: str, value) -> tuple:
    try:
        a, b = value
    except (TypeError, ValueError):
        raise InputError(name, f"must be a pair (x, y), got {value!r}") from None
    return a, b
