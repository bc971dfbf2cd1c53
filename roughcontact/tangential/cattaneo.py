"""The discrete Cattaneo theorem: partial slip from a second normal solve (§4.2, Eqs. 20–24).

Under a tangential load Q < fP applied monotonically at constant normal
load P, the shear traction is the full-sliding traction f p minus a
correction f p* that vanishes on the slip set (Eq. 21). With the γ = 0
kernel (Eq. 17) the correction satisfies the normal contact equations on
the stick set for a smaller approach δz* and the SAME rotation as the
actual normal problem (Eq. 23), so

- p* is the normal solution at P* = P − Q/f with the rotation fixed
  (a load-controlled solve of :class:`~roughcontact.normal.ActiveSetSolver`);
- the stick set is the contact set of p*, the slip set the rest of the
  contact set of p;
- q = f (p − p*) along Q (Eq. 21) and δx = f (δz − δz*) (Eq. 24);
- on the contact set u_x = f (u_z − H p*) = δx − f g*, with g* the deformed
  gap of the corrective problem: u_x = δx in the stick set (Eq. 20) and the
  slip is g = f g* ≥ 0 in the slip set.

At Q = fP the correction vanishes (p* = 0) and displacements are no longer
determined; :meth:`CattaneoSolver.incipient_sliding` returns the limit
Q → fP⁻, whose dissipated energy is Eq. 27.

References: C. Cattaneo, Rend. Accad. Naz. Lincei 27 (1938) 342–348;
J.R. Barber, M. Ciavarella, Int. J. Solids Struct. 37 (2000) 29–43
(the correction theorem); M. Ciavarella, Int. J. Solids Struct. 35 (1998)
2349–2362 and J. Jäger, Wear 209 (1997) 210–220 (Q = f(P − P*)).
"""
from __future__ import annotations

import time
import warnings

import numpy as np

from ..collective import Collective
from ..errors import ConvergenceError, InputError
from ..normal.choice import choose_method
from ..normal.factory import make_solver, solver_class
from ..normal.problem import NormalProblem
from ..normal.result import NormalResult
from .checks import check_direction, check_friction, check_normal, check_tangential, full_sliding
from .contact_set import ContactSetSolver, contact_set_pays
from .energy import frictional_energy, stored_energy
from .model import COULOMB_TOLERANCE, CattaneoConsistencyWarning, cattaneo_model
from .result import TangentialState, centroid_of


def first_touch_gap(problem: NormalProblem, rotation: tuple[float, float]) -> np.ndarray:
    """Undeformed gap Δh on the footprint (global vector) with ``rotation`` fixed, zero at first touch.

    This is the deformed gap of the corrective problem in the limit P* → 0
    (Eq. 23 with p* = 0): the Δh of Eq. 27.
    """
    w0 = problem.gather(problem.interpenetration(np.array([0.0, *rotation])))
    return w0.max() - w0


def incipient_sliding_energy(problem: NormalProblem, normal: NormalResult, friction: float) -> float:
    """E_tot = Σ_S f² p̄ Δh (Eq. 27): the energy dissipated from Q = 0 to incipient full sliding, J.

    Δh is the undeformed gap at first touch with the rotation of ``normal``
    fixed (:func:`first_touch_gap`). Needs no corrective solve, so E_tot
    against P (Fig. 12) costs one normal solve per load.
    """
    friction = check_friction(friction)
    check_normal(problem, normal)
    gap = problem.to_field(first_touch_gap(problem, normal.rotation), np.nan)
    return float(friction**2 * np.sum(normal.force[normal.contact] * gap[normal.contact]))


class CattaneoSolver(Collective):
    """Tangential states of one normal contact under Q along ``direction`` (Eqs. 20–27).

    Keeps one corrective normal solver (:func:`~roughcontact.normal.make_solver`),
    so a sweep of increasing Q (decreasing P*) starts each corrective solve
    from the line through the last two corrective solutions in P* (the first
    of them the actual one, p* = p at Q = 0), cut at p* ≥ 0; the first
    starts from the actual contact set.

    Parameters
    ----------
    problem
        The :class:`~roughcontact.normal.NormalProblem` that ``normal`` solved.
    normal
        The actual normal solution (load P > 0, approach δz, rotation).
    friction
        Coulomb coefficient f > 0.
    direction
        In-plane direction of Q, any non-zero vector (normalised here).
    method
        The corrective solver's method (``"auto"``, ``"ksp"``, ``"gauss-seidel"``, ``"cg"``);
        ``"auto"`` is resolved by :func:`~roughcontact.normal.make_solver`.
    restrict
        Where the method is the CG and the actual contact set's explicit
        matrix pays (:func:`~.contact_set.contact_set_pays`), solve each
        corrective problem on the contact set and confirm it on the whole
        footprint (:class:`~.contact_set.ContactSetSolver`: the same states;
        the 513² sweep in 0.35–0.47 of the time in the runs measured); False
        solves on the whole footprint only.
    **solver_options
        Its options: ``settings``, ``rtol``, ``options``, ``prefix`` for the
        active set, ``settings``, ``nested`` for the CG; one the resolved
        method does not take is an :class:`InputError`. The active-set
        methods, whether given or picked by ``"auto"``, read PETSc options
        under the prefix ``cattaneo_`` by default (``-cattaneo_ksp_monitor``).

    Notes
    -----
    For materials with β ≠ 0 or γ ≠ 0 the states are the uncoupled
    approximation, labelled in :attr:`model` (warned once per process).
    """

    def __init__(self, problem: NormalProblem, normal: NormalResult, friction: float,
                 direction=(1.0, 0.0), method: str = "auto", restrict: bool = True, **solver_options):
        self.friction = check_friction(friction)
        self.direction = check_direction(direction)
        check_normal(problem, normal)
        self.problem = problem
        self.normal = normal
        self.model = cattaneo_model(problem.interface)
        name, _ = choose_method(problem.operator_kind, problem.size, method)
        if "prefix" in solver_class(name).OPTIONS:
            solver_options.setdefault("prefix", "cattaneo_")
        if not isinstance(restrict, (bool, np.bool_)):
            raise InputError("restrict", f"must be True or False, got {restrict!r}")
        self.solver = make_solver(problem, method, **solver_options)
        try:
            if restrict and name == "cg" and contact_set_pays(problem, normal.contact):
                self.solver = ContactSetSolver(problem, normal, self.solver)
            # warm start of the first corrective solve: the actual contact set and motion (Eq. 23
            # receding: the stick set is a subset of it)
            self.solver.warm_start(normal)
        except BaseException:
            self.solver.destroy()
            raise
        # (P*, p* on this rank, δz*) of the last corrective solutions; at Q = 0 p* is p itself
        self._history = [(normal.load, self.solver.forces.copy(), float(normal.closure))]

    @property
    def limit_load(self) -> float:
        """fP, the tangential load of incipient full sliding (N)."""
        return self.friction * self.normal.load

    def _release(self) -> None:
        """Free the corrective solver (collective)."""
        self.solver.destroy()

    # ------------------------------------------------------------------ API
    def solve(self, tangential: float) -> TangentialState:
        """The partial-slip state at Q, 0 ≤ Q < fP (Eqs. 21–26).

        Raises
        ------
        InputError
            ``tangential`` negative, not finite, or ≥ fP (full sliding:
            displacements undetermined).
        """
        self._check_alive()
        t0 = time.perf_counter()
        f, normal = self.friction, self.normal
        q_load = check_tangential(tangential, f, normal.load)
        if q_load == 0.0:
            # no shear: the corrective problem is the actual one
            corrective = normal
            traction = np.zeros_like(normal.force)
            stick = normal.contact.copy()
        else:
            corrective_load = normal.load - q_load / f
            self._extrapolate(corrective_load)
            try:
                corrective = self.solver.solve_load(corrective_load, rotation=normal.rotation)
            except ConvergenceError as err:
                # A load-controlled normal solve meets its load only to its load tolerance (the
                # solved P differs from the imposed one by ~1e-13 relative in practice), so Q = fP
                # reached as np.linspace(0, f * P, n)[-1] may sit a hair below f times the solved
                # P, and P* = P − Q/f is then below the resolution of P itself. Within that
                # tolerance of fP a failed corrective solve means full sliding; one that succeeds
                # (P* = 1e-9 P still leaves a sticking node) is kept.
                load_tol = self.solver.settings.load_tol
                if q_load >= self.limit_load * (1.0 - load_tol):
                    raise full_sliding("tangential", q_load, self.limit_load, within=load_tol) from err
                raise
            self._remember(corrective_load)
            # Eq. 21; the stick set lies inside the contact set (receding problem), and a node of
            # p* outside it would show as negative traction in coulomb_violation
            stick = corrective.contact.copy()
            traction = f * (normal.force - corrective.force)
        slip = normal.contact & ~stick
        slip_distance = np.where(normal.contact, 0.0, np.nan)
        slip_distance[slip] = f * corrective.gap[slip]
        approach = f * (normal.closure - corrective.closure)
        # u_x = H q̄ = f (H p − H p*) (Eqs. 17, 21), and H p = g + w(δz) for each solution, with the
        # same rotation (Eq. 23): u_x = δx + f (g − g*) on the footprint (Eq. 24), NaN off it; δx on
        # the stick set (Eq. 20), δx − f g* on the slip set. The gaps are the solves' own, exact off
        # their contact sets and zero on them to the solves' tolerance: no product per state
        displacement = approach + f * (normal.gap - corrective.gap)
        return self._state(q_load, corrective, traction, stick, slip, slip_distance, approach,
                           normal.load - q_load / f, corrective.closure, limit=False, t0=t0,
                           displacement=displacement)

    def incipient_sliding(self) -> TangentialState:
        """The limit Q → fP⁻ of incipient full sliding (§5.2, Eq. 27).

        p* → 0 and the stick set shrinks to the node(s) touching first with the
        rotation fixed, δz* → the approach at first touch, q = f p everywhere,
        and the slip is g = f Δh with Δh the undeformed gap at first touch, so
        E_f = Σ_S f² p̄ Δh = E_tot (Eq. 27). Beyond this limit displacements are
        undetermined.
        """
        self._check_alive()
        t0 = time.perf_counter()
        f, normal, pb = self.friction, self.normal, self.problem
        gap = pb.to_field(first_touch_gap(pb, normal.rotation), np.nan)
        first_touch = float(normal.closure - pb.allmax(pb.interpenetration(
            np.array([normal.closure, *normal.rotation])).max(initial=-np.inf)))
        traction = np.where(normal.contact, f * normal.force, 0.0)
        stick = np.zeros_like(normal.contact)
        slip = normal.contact.copy()
        slip_distance = np.where(slip, f * gap, np.nan)
        approach = f * (normal.closure - first_touch)
        return self._state(self.limit_load, None, traction, stick, slip, slip_distance, approach,
                           0.0, first_touch, limit=True, t0=t0)

    # ------------------------------------------------------------ internals
    def _remember(self, corrective_load: float) -> None:
        """Keep the last two corrective solutions (this rank's p*, δz*) for :meth:`_extrapolate`."""
        self._history = self._history[-1:] + [(corrective_load, self.solver.forces.copy(),
                                               float(self.solver.rigid[0]))]

    def _extrapolate(self, corrective_load: float) -> None:
        """Start the solve at P* from the line through the last two corrective solutions.

        p*(P*) is piecewise smooth in P* (the stick set recedes node by node, Eq. 23): the linear
        extrapolation, cut at p* ≥ 0, starts a decreasing sweep where the last solution alone
        leaves the receding edges of every stick cluster to the iteration."""
        if len(self._history) < 2:
            return
        (load0, forces0, closure0), (load1, forces1, closure1) = self._history
        if not load1 < load0 or not corrective_load < load1:
            return
        ratio = (corrective_load - load1) / (load1 - load0)
        rigid = np.array([closure1 + ratio * (closure1 - closure0), *self.normal.rotation])
        self.solver.start_from(forces1 + ratio * (forces1 - forces0), rigid)

    def _state(self, q_load, corrective, traction, stick, slip, slip_distance, approach,
               corrective_load, corrective_closure, limit, t0, displacement=None) -> TangentialState:
        f, normal, pb = self.friction, self.normal, self.problem
        s = pb.topography.spacing
        if displacement is None:
            displacement = self._displacement(traction)
        q_stick = float(traction[stick].sum())
        q_slip = float(traction[slip].sum())
        contact = normal.contact
        p_max = float(normal.force.max())
        excess = np.maximum(traction - f * normal.force, -traction)[contact | stick]
        violation = max(0.0, float(excess.max(initial=0.0)) / (f * p_max)) if p_max > 0 else 0.0
        if violation > COULOMB_TOLERANCE:
            warnings.warn(f"Q = {q_load:.6g} N: the shear breaks 0 <= q <= f p by {violation:.2e} of "
                          "f max p (coulomb_violation); the discrete corrective pressure exceeds the "
                          "actual one at some node", CattaneoConsistencyWarning, stacklevel=3)
        return TangentialState(
            tangential=float(q_load), friction=f, direction=self.direction, normal=normal,
            corrective=corrective, traction=traction, stick=stick, slip=slip,
            displacement=displacement, slip_distance=slip_distance,
            tangential_approach=float(approach), corrective_load=float(corrective_load),
            corrective_closure=float(corrective_closure),
            stick_area=float(stick.sum()) * s**2, slip_area=float(slip.sum()) * s**2,
            stick_force=q_stick, slip_force=q_slip,
            centroid=centroid_of(traction, contact, s), stick_centroid=centroid_of(traction, stick, s),
            slip_centroid=centroid_of(traction, slip, s),
            frictional_energy=frictional_energy(normal.force, slip_distance, slip, f),
            stored_energy=stored_energy(traction, displacement),
            coulomb_violation=violation, model=self.model, limit=limit, spacing=s,
            elapsed=time.perf_counter() - t0, gamma=float(self.problem.interface.composite_poisson),
            beta=float(self.problem.interface.dundurs_beta))

    def _displacement(self, traction: np.ndarray) -> np.ndarray:
        """u_x = H q̄ (Eq. 17) on the footprint, NaN outside it, by one product: the incipient-sliding
        limit's (a partial-slip state's comes from the two solves' gaps, :meth:`solve`)."""
        pb = self.problem
        values = traction[pb.topography.footprint][pb.start:pb.stop]
        return pb.to_field(pb.gather(pb.displacement(values)), np.nan)
