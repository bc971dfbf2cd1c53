"""Elastic constants of the two bodies and of their interface (paper §2).

The normal problem depends on the composite compliance A (Eq. 4a); the
uncoupled formulation of the paper is exact only when Dundurs' β = 0 (Eq. 5,
normal and tangential problems uncoupled) and, for the tangential Cattaneo
analogy, also the composite Poisson ratio γ = 0 (Eq. 4b, §4.1). Both are
reported with every result so a user sees when the model is exact.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import InputError


@dataclass(frozen=True)
class Material:
    """An isotropic linear-elastic body.

    Parameters
    ----------
    E
        Young's modulus (Pa), > 0; ``math.inf`` for a rigid body.
    nu
        Poisson's ratio in (−1, 0.5].
    """

    E: float
    nu: float

    def __post_init__(self):
        try:
            E, nu = float(self.E), float(self.nu)
        except (TypeError, ValueError):
            raise InputError("E", f"E and nu must be numbers, got E={self.E!r}, nu={self.nu!r}") from None
        if math.isnan(E) or E <= 0.0:
            raise InputError("E", f"Young's modulus must be > 0, got {self.E!r}")
        if math.isnan(nu) or not (-1.0 < nu <= 0.5):
            raise InputError("nu", f"Poisson's ratio must lie in (-1, 0.5], got {self.nu!r}")
        object.__setattr__(self, "E", E)
        object.__setattr__(self, "nu", nu)

    @classmethod
    def rigid(cls) -> "Material":
        """A rigid body (infinite modulus)."""
        return cls(math.inf, 0.0)

    @property
    def is_rigid(self) -> bool:
        return math.isinf(self.E)

    @property
    def shear_modulus(self) -> float:
        """μ = E / (2 (1 + ν)) (Pa)."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def kolosov(self) -> float:
        """Kolosov's constant κ = 3 − 4ν (plane strain), as in Eq. 5."""
        return 3.0 - 4.0 * self.nu


@dataclass(frozen=True)
class Interface:
    """Two bodies in contact; ``body2`` defaults to a rigid flat.

    Attributes computed from the paper: :attr:`compliance` A (Eq. 4a),
    :attr:`composite_poisson` γ (Eq. 4b), :attr:`dundurs_beta` β (Eq. 5).
    """

    body1: Material
    body2: Material = Material.rigid()

    def __post_init__(self):
        for name in ("body1", "body2"):
            if not isinstance(getattr(self, name), Material):
                raise InputError(name, f"must be a Material, got {type(getattr(self, name)).__name__}")
        if self.body1.is_rigid and self.body2.is_rigid:
            raise InputError("body1", "both bodies are rigid: at least one must be elastic")

    @staticmethod
    def _term(m: Material, numerator: float) -> float:
        return 0.0 if m.is_rigid else numerator / m.shear_modulus

    @property
    def compliance(self) -> float:
        """A = (1 − ν1)/μ1 + (1 − ν2)/μ2 (Eq. 4a), equal to 2/E* (m²/N)."""
        return (self._term(self.body1, 1.0 - self.body1.nu)
                + self._term(self.body2, 1.0 - self.body2.nu))

    @property
    def contact_modulus(self) -> float:
        """Johnson's composite modulus E* = 2/A (Pa)."""
        return 2.0 / self.compliance

    @property
    def composite_poisson(self) -> float:
        """γ = (ν1/μ1 + ν2/μ2) / A (Eq. 4b)."""
        return (self._term(self.body1, self.body1.nu) + self._term(self.body2, self.body2.nu)) / self.compliance

    @property
    def dundurs_beta(self) -> float:
        """Dundurs' second constant β (Eq. 5); 0 for elastically similar bodies."""
        b1, b2 = self.body1, self.body2
        if b2.is_rigid:
            return (b1.kolosov - 1.0) / (b1.kolosov + 1.0)
        if b1.is_rigid:
            return -(b2.kolosov - 1.0) / (b2.kolosov + 1.0)
        mu1, mu2 = b1.shear_modulus, b2.shear_modulus
        return ((mu2 * (b1.kolosov - 1.0) - mu1 * (b2.kolosov - 1.0))
                / (mu2 * (b1.kolosov + 1.0) + mu1 * (b2.kolosov + 1.0)))

    @property
    def normal_uncoupled_exact(self) -> bool:
        """True when β = 0: the normal problem is exactly uncoupled (Eq. 6)."""
        return abs(self.dundurs_beta) < 1e-12

    @property
    def cattaneo_exact(self) -> bool:
        """True when β = 0 and γ = 0: the Cattaneo analogy is exact (§4.1)."""
        return self.normal_uncoupled_exact and abs(self.composite_poisson) < 1e-12

    def attrs(self) -> dict[str, float | int]:
        """Constants for a results file's attributes."""
        return {
            "E1": self.body1.E, "nu1": self.body1.nu, "E2": self.body2.E, "nu2": self.body2.nu,
            "composite_compliance_A": self.compliance, "contact_modulus_Estar": self.contact_modulus,
            "composite_poisson_gamma": self.composite_poisson, "dundurs_beta": self.dundurs_beta,
            "normal_uncoupled_exact": int(self.normal_uncoupled_exact),
            "cattaneo_exact": int(self.cattaneo_exact),
        }
