"""The tangential state of a rough contact at one shear load Q (§4.2, §5)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..normal.result import NormalResult


class LoadedContact:
    """The load measures shared by the tangential states: P, Q / (f P) and the contact area.

    Needs the fields ``normal`` (the actual normal solution), ``tangential``
    (Q along the load direction) and ``friction`` (f).
    """

    @property
    def normal_load(self) -> float:
        """P of the actual normal problem (N)."""
        return self.normal.load

    @property
    def load_ratio(self) -> float:
        """Q / (f P)."""
        return self.tangential / (self.friction * self.normal.load)

    @property
    def contact_area(self) -> float:
        """Area of the normal contact set (m²)."""
        return self.normal.contact_area


@dataclass(frozen=True)
class TangentialState(LoadedContact):
    """Partial slip under a monotonically applied Q at constant P, identical on every rank.

    Fields are (nx, ny) arrays on the topography's grid. Forces are nodal
    resultants (N) like the normal problem's p̄ (Eq. 9); coordinates are in
    the grid's frame (node (i, j) at (i s, j s)). The shear acts along the unit
    vector ``direction`` = e; ``traction`` and the displacements are the
    components along e (the γ = 0 kernel is isotropic, so nothing acts across e).

    Attributes
    ----------
    tangential
        Q (N), 0 ≤ Q ≤ fP; Q = fP only for the limit state of incipient sliding.
    friction
        Coulomb coefficient f.
    direction
        Unit vector e of Q in the (x, y) plane.
    normal
        The actual normal solution (load P, approach δz, rotation, pressure p̄).
    corrective
        The corrective normal solution at P* = P − Q/f with the rotation of
        ``normal`` fixed (Eq. 23); ``None`` in the limit Q → fP, where p* = 0.
    traction
        Nodal shear force q̄ = f (p̄ − p̄*) along e (Eq. 21), N.
    stick, slip
        Stick set (contact set of p*) and slip set (the rest of the contact set).
    displacement
        Elastic tangential surface displacement u_x = H q̄ (Eq. 17) on the
        footprint, m (NaN outside it): δx + f (g − g*) from the two solves'
        gaps (H q̄ = f (H p − H p*), the rotation the same; Eqs. 20, 24), which
        equals H q̄ to the solves' tolerance, and exactly δx on the stick set;
        the incipient-sliding limit's by a product.
    slip_distance
        Relative slip g = δx − u_x = f × (deformed gap of the corrective
        problem) on the slip set (Eqs. 22–23), 0 on the stick set, NaN off contact.
    tangential_approach
        δx = f (δz − δz*) (Eq. 24), m.
    corrective_load, corrective_closure
        P* and δz* of Eq. 23.
    stick_force, slip_force
        Q_stick and Q_slip, the shear carried by each zone (Fig. 10b).
    centroid, stick_centroid, slip_centroid
        G_Q (Eq. 25), G_Q(stick), G_Q(slip) (= G_P(slip)), m; NaN for an
        empty zone or Q = 0.
    frictional_energy
        E_f = Σ_slip f p̄ g (Eq. 26), J: the energy dissipated so far under
        monotonic loading (a slipping node keeps q = f p while it slips).
    stored_energy
        U = ½ Σ q̄ u_x, the tangential elastic energy (J).
    coulomb_violation
        max over the contact set of max(q̄ − f p̄, −q̄) / (f max p̄): ≤ solver
        tolerance when Coulomb's inequalities (Eq. 14a) hold.
    model
        ``"exact"`` (β = γ = 0) or ``"uncoupled approximation"``.
    limit
        True for the limit state Q → fP⁻ of incipient full sliding.
    spacing
        Grid spacing s (m).
    elapsed
        Wall time to build this state (the corrective solve and the post-processing), s.
    gamma, beta
        Composite Poisson ratio γ (Eq. 4b) and Dundurs' β (Eq. 5) of the
        interface: the model is exact when both vanish.
    """

    tangential: float
    friction: float
    direction: tuple[float, float]
    normal: NormalResult
    corrective: NormalResult | None
    traction: np.ndarray
    stick: np.ndarray
    slip: np.ndarray
    displacement: np.ndarray
    slip_distance: np.ndarray
    tangential_approach: float
    corrective_load: float
    corrective_closure: float
    stick_area: float
    slip_area: float
    stick_force: float
    slip_force: float
    centroid: tuple[float, float]
    stick_centroid: tuple[float, float]
    slip_centroid: tuple[float, float]
    frictional_energy: float
    stored_energy: float
    coulomb_violation: float
    model: str
    limit: bool
    spacing: float
    elapsed: float
    gamma: float = 0.0
    beta: float = 0.0

    @property
    def shear_stress(self) -> np.ndarray:
        """q̄ / s² (Pa)."""
        return self.traction / self.spacing**2

    @property
    def traction_vector(self) -> tuple[np.ndarray, np.ndarray]:
        """(q̄_x, q̄_y) = q̄ e."""
        return self.traction * self.direction[0], self.traction * self.direction[1]

    @property
    def approach_vector(self) -> tuple[float, float]:
        """(δ_x, δ_y) = δx e, the relative rigid translation of Eq. 20."""
        return self.tangential_approach * self.direction[0], self.tangential_approach * self.direction[1]

    @property
    def frictional_energy_density(self) -> np.ndarray:
        """Energy dissipated per node, f p̄ g on the slip set, 0 elsewhere (Eq. 26), J."""
        return np.where(self.slip, self.friction * self.normal.force * np.nan_to_num(self.slip_distance), 0.0)

    def summary(self) -> str:
        tag = " [incipient sliding limit]" if self.limit else ""
        return (f"Q={self.tangential:.6g} N (Q/fP={self.load_ratio:.4f}), δx={self.tangential_approach:.6g} m, "
                f"A_stick={self.stick_area:.4g} m², A_slip={self.slip_area:.4g} m², "
                f"Q_stick={self.stick_force:.4g} N, Q_slip={self.slip_force:.4g} N, "
                f"E_f={self.frictional_energy:.4g} J, {self.model}{tag}")


def centroid_of(traction: np.ndarray, zone: np.ndarray, spacing: float) -> tuple[float, float]:
    """Centroid of the shear forces in ``zone`` (grid frame, m); NaN if they sum to zero."""
    total = float(traction[zone].sum())
    if total <= 0.0:
        return (math.nan, math.nan)
    i, j = np.nonzero(zone)
    weights = traction[zone]
    return (float(weights @ i) * spacing / total, float(weights @ j) * spacing / total)
