"""The coupled tangential solver: partial slip with the γ coupling of Eqs. 15–16 kept (β = 0).

The reference the uncoupled Cattaneo construction (Eqs. 21–24) is measured
against. The normal problem is solved first and stays fixed (β = 0: pressure
and shear do not couple, Eq. 5); the shear on its contact set then follows
the load path incrementally (:mod:`.increment`): each call of
:meth:`CoupledTangentialSolver.solve` (load control, Q along the direction e)
or :meth:`CoupledTangentialSolver.solve_approach` (the rigid translation δ
along e) is one increment from the state the solver holds. A monotonic sweep
is a sequence of increasing loads (:func:`~.sweep.coupled_sweep`); any other
sequence is a load history, reversals included, solved without memory rules.
"""
from __future__ import annotations

import time

import numpy as np

from ...checks import require_finite
from ...collective import Collective
from ...errors import InputError
from ...materials import Interface
from ...normal.problem import NormalProblem
from ...normal.result import NormalResult
from ..checks import check_direction, check_friction, check_normal, full_sliding
from ..result import centroid_of
from .increment import DISPLACEMENT, LOAD, CoupledSettings, Increment, IncrementSolver
from .operator import ShearOperator
from .result import CoupledState


def check_coupled_interface(interface: Interface) -> float:
    """γ (Eq. 4b) of an interface the coupled solver covers, or :class:`InputError` saying why not.

    It needs β = 0 (Eq. 5; otherwise pressure and shear couple through Eqs.
    1–3) and 0 ≤ ν ≤ 0.5 for both bodies (γ in [0, 1], the range in which T is
    checked to be positive definite and the uncoupled model's error is charted).
    """
    for name in ("body1", "body2"):
        body = getattr(interface, name)
        if not body.is_rigid and not 0.0 <= body.nu <= 0.5:
            raise InputError("nu", f"the coupled solver covers 0 <= nu <= 0.5 (gamma in [0, 1]); {name} has "
                                   f"nu = {body.nu:g}")
    beta = interface.dundurs_beta
    if abs(beta) > 1e-12:
        raise InputError("interface", f"the coupled solver needs Dundurs' beta = 0 (Eq. 5: elastically similar "
                                      f"bodies), this interface has beta = {beta:.3g}: pressure and shear then "
                                      "couple (Eqs. 1-3), which it does not solve")
    return float(interface.composite_poisson)


class CoupledTangentialSolver(Collective):
    """Coupled partial slip of one normal contact under a tangential load along ``direction``.

    Parameters
    ----------
    problem
        The :class:`~roughcontact.normal.NormalProblem` that ``normal`` solved
        (operator ``"dense"`` or ``"fft"``).
    normal
        The actual normal solution (P > 0, its contact set and pressure).
    friction
        Coulomb coefficient f > 0.
    direction
        In-plane direction e of the load, any non-zero vector (normalised here).
    settings
        :class:`~.increment.CoupledSettings` (tolerances, iteration limits).
    options, prefix
        PETSc options of the Krylov solves, under ``prefix`` (``-coupled_ksp_monitor``).
    """

    def __init__(self, problem: NormalProblem, normal: NormalResult, friction: float, direction=(1.0, 0.0),
                 settings: CoupledSettings = CoupledSettings(), options: dict | None = None,
                 prefix: str = "coupled_"):
        self.friction = check_friction(friction)
        self.direction = check_direction(direction)
        check_normal(problem, normal)
        self.gamma = check_coupled_interface(problem.interface)
        problem._check_alive()
        self.problem, self.normal = problem, normal
        footprint = problem.topography.footprint
        force = normal.force[footprint][problem.start:problem.stop]
        self.nodes = np.flatnonzero(normal.contact[footprint][problem.start:problem.stop] & (force > 0.0))
        self.operator = ShearOperator(problem, self.gamma)
        self.increments = IncrementSolver(problem, self.operator, self.nodes, self.friction * force[self.nodes],
                                          settings, prefix=prefix, options=options)
        n, size = self.nodes.size, problem.local_size
        self.traction = np.zeros((2, n))
        self.displacement = np.zeros((2, size))
        self.stick = np.ones(n, dtype=bool)
        self.curvature = np.zeros(n)
        self.translation = np.zeros(2)
        self.slipped = np.zeros((2, n))
        self.energy = 0.0

    @property
    def limit_load(self) -> float:
        """fP (N)."""
        return self.friction * self.normal.load

    def _release(self) -> None:
        self.increments.destroy()
        self.operator.destroy()

    # ------------------------------------------------------------------ API
    def solve(self, tangential: float) -> CoupledState:
        """One increment to the load Q e (load control, Eq. 19), |Q| < fP; Q < 0 loads along −e.

        Raises
        ------
        InputError
            ``tangential`` not finite or |Q| ≥ fP (full sliding).
        ConvergenceError
            The increment's Newton or Krylov iteration failed (named reason).
        """
        self._check_alive()
        q_load = require_finite("tangential", tangential)
        if abs(q_load) >= self.limit_load:
            raise full_sliding("tangential", abs(q_load), self.limit_load)
        t0 = time.perf_counter()
        increment = self.increments.solve(self.traction, self.displacement, self.stick, self.curvature, LOAD,
                                          q_load * np.asarray(self.direction))
        return self._advance(increment, t0)

    def solve_approach(self, approach: float) -> CoupledState:
        """One increment to the rigid translation δ e (displacement control, Eq. 20)."""
        self._check_alive()
        target = require_finite("approach", approach) * np.asarray(self.direction)
        t0 = time.perf_counter()
        increment = self.increments.solve(self.traction, self.displacement, self.stick, self.curvature,
                                          DISPLACEMENT, target - self.translation)
        return self._advance(increment, t0)

    # ------------------------------------------------------------ internals
    def _advance(self, increment: Increment, t0: float) -> CoupledState:
        pb = self.problem
        self.energy += float(pb.allsum(np.einsum("ij,ij->", increment.traction, increment.slip)))
        self.slipped = self.slipped + np.where(increment.stick, 0.0, increment.slip)
        self.traction, self.displacement = increment.traction, increment.displacement
        self.stick, self.curvature = increment.stick, increment.curvature
        self.translation = self.translation + increment.translation
        return self._state(increment, t0)

    def _field(self, values: np.ndarray, fill: float) -> np.ndarray:
        """A grid field from values on this rank's contact nodes (``fill`` elsewhere on the footprint)."""
        pb = self.problem
        local = np.full(pb.local_size, fill, dtype=values.dtype)
        local[self.nodes] = values
        return pb.to_field(pb.gather(local), fill)

    def _state(self, increment: Increment, t0: float) -> CoupledState:
        pb, f, normal = self.problem, self.friction, self.normal
        s = pb.topography.spacing
        qx, qy = self._field(self.traction[0], 0.0), self._field(self.traction[1], 0.0)
        stick = self._field(self.stick, False)
        contact = self._field(np.ones(self.nodes.size, dtype=bool), False)
        slip = contact & ~stick
        ex, ey = self.direction
        along = qx * ex + qy * ey
        total = float(along.sum())
        sign = 1.0 if total >= 0.0 else -1.0
        ux = pb.to_field(pb.gather(self.displacement[0]), np.nan)
        uy = pb.to_field(pb.gather(self.displacement[1]), np.nan)
        gx, gy = self._field(self.slipped[0], np.nan), self._field(self.slipped[1], np.nan)
        magnitude = np.hypot(qx, qy)
        p_max = float(normal.force.max())
        excess = (magnitude - f * normal.force)[contact].max(initial=0.0)
        return CoupledState(
            tangential=total, friction=f, direction=self.direction, normal=normal, gamma=self.gamma,
            traction_x=qx, traction_y=qy, stick=stick, slip=slip, displacement_x=ux, displacement_y=uy,
            slip_x=gx, slip_y=gy, approach=(float(self.translation[0]), float(self.translation[1])),
            frictional_energy=self.energy,
            stored_energy=0.5 * float(np.sum(qx[contact] * ux[contact] + qy[contact] * uy[contact])),
            stick_area=float(stick.sum()) * s**2, slip_area=float(slip.sum()) * s**2,
            stick_force=(float(qx[stick].sum()), float(qy[stick].sum())),
            slip_force=(float(qx[slip].sum()), float(qy[slip].sum())),
            centroid=centroid_of(sign * along, contact, s), stick_centroid=centroid_of(sign * along, stick, s),
            slip_centroid=centroid_of(sign * along, slip, s),
            coulomb_violation=max(0.0, float(excess)) / (f * p_max) if p_max > 0 else 0.0,
            iterations=increment.iterations, linear_iterations=increment.linear_iterations,
            residual=increment.residual, spacing=s, elapsed=time.perf_counter() - t0)

