"""The coupled tangential state at one load (Eqs. 14–20 with the γ terms of Eqs. 15–16) and a sweep of them."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...normal.result import NormalResult
from ..result import LoadedContact
from ..sweep import TangentialSweep

COUPLED = "coupled"


@dataclass(frozen=True)
class CoupledState(LoadedContact):
    """Partial slip with the shear components coupled through γ, identical on every rank.

    Fields are (nx, ny) arrays on the topography's grid; forces are nodal
    resultants (N) as in the normal problem (Eq. 9). The load acts along the
    unit vector ``direction`` = e; the shear has components along e and
    across it (q_y ≠ 0 although Q_y = 0: the coupling of Eq. 16).

    Attributes
    ----------
    tangential
        Q along e (N); the load vector is Q e (Eq. 19).
    friction, direction, normal
        f, e and the actual normal solution (P, p̄, contact set).
    gamma
        Composite Poisson ratio γ (Eq. 4b) of the operator.
    traction_x, traction_y
        Nodal shear forces q̄ (N), 0 off contact.
    stick, slip
        Stick set (|q̄| < f p̄, moving with the rigid translation, Eq. 20) and
        slip set (|q̄| = f p̄ along the slip, Eq. 14b); they partition the contact set.
    displacement_x, displacement_y
        Elastic tangential displacements u = T q̄ (Eqs. 15–16) on the footprint, m (NaN outside).
    slip_x, slip_y
        Slip accumulated since Q = 0, g = δ − u (m): 0 on nodes that never slipped, NaN off contact.
    approach
        The rigid translation (δx, δy) of Eq. 20 (m).
    frictional_energy
        Energy dissipated since Q = 0, Σ over increments of Σ q̄ · Δg (J), Eq. 26 step by step.
    stored_energy
        U = ½ q̄ · T q̄ (J).
    stick_area, slip_area
        Areas of the zones (m²).
    stick_force, slip_force
        Shear carried by each zone, (x, y) vectors (N).
    centroid, stick_centroid, slip_centroid
        Centroids of the shear along e, Σ x (q̄·e) / Σ (q̄·e) (Eq. 25), m; NaN when empty.
    coulomb_violation
        max (|q̄| − f p̄) / (f max p̄) over the contact set (≤ tol of the increment).
    iterations, linear_iterations, residual
        Newton iterations, Krylov iterations and final residual of the last increment.
    spacing, elapsed
        Grid spacing s (m) and wall time of the increment (s).
    """

    tangential: float
    friction: float
    direction: tuple[float, float]
    normal: NormalResult
    gamma: float
    traction_x: np.ndarray
    traction_y: np.ndarray
    stick: np.ndarray
    slip: np.ndarray
    displacement_x: np.ndarray
    displacement_y: np.ndarray
    slip_x: np.ndarray
    slip_y: np.ndarray
    approach: tuple[float, float]
    frictional_energy: float
    stored_energy: float
    stick_area: float
    slip_area: float
    stick_force: tuple[float, float]
    slip_force: tuple[float, float]
    centroid: tuple[float, float]
    stick_centroid: tuple[float, float]
    slip_centroid: tuple[float, float]
    coulomb_violation: float
    iterations: int
    linear_iterations: int
    residual: float
    spacing: float
    elapsed: float
    model: str = COUPLED
    limit: bool = False

    @property
    def tangential_approach(self) -> float:
        """δ · e, the translation along the load (m): the δx of Eq. 24."""
        return self.approach[0] * self.direction[0] + self.approach[1] * self.direction[1]

    @property
    def traction(self) -> np.ndarray:
        """q̄ · e, the shear along the load (N)."""
        return self.traction_x * self.direction[0] + self.traction_y * self.direction[1]

    @property
    def cross_traction(self) -> np.ndarray:
        """q̄ · e⊥, the shear across the load (N), e⊥ = e turned by +90°."""
        return self.traction_y * self.direction[0] - self.traction_x * self.direction[1]

    @property
    def stick_force_along(self) -> float:
        """Q_stick along e (N)."""
        return self.stick_force[0] * self.direction[0] + self.stick_force[1] * self.direction[1]

    @property
    def slip_force_along(self) -> float:
        """Q_slip along e (N)."""
        return self.slip_force[0] * self.direction[0] + self.slip_force[1] * self.direction[1]

    def summary(self) -> str:
        return (f"Q={self.tangential:.6g} N (Q/fP={self.load_ratio:.4f}), δ=({self.approach[0]:.6g}, "
                f"{self.approach[1]:.6g}) m, A_stick={self.stick_area:.4g} m², A_slip={self.slip_area:.4g} m², "
                f"E_f={self.frictional_energy:.4g} J, γ={self.gamma:.4g}, Newton {self.iterations}, "
                f"Krylov {self.linear_iterations}")


@dataclass(frozen=True)
class CoupledSweep(TangentialSweep):
    """Coupled states along a load path at constant P, in the order solved.

    Reads as a :class:`~..sweep.TangentialSweep` (Q, δ · e, W = ∫ Q dδx);
    ``resticking_nodes`` counts nodes that joined the stick set between two
    states, which here costs nothing: E_f is summed increment by increment.
    """

    states: tuple[CoupledState, ...]
