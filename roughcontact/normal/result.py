"""Result of a normal contact solve (paper §2–§3.1)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..errors import InputError


class ContactState(NamedTuple):
    """A converged contact state on this rank's nodes, before it becomes a :class:`NormalResult`."""

    pressure: np.ndarray          # nodal forces p̄ (N)
    active: np.ndarray            # contact set S
    gap: np.ndarray               # deformed gap (m), 0 on S
    outer: int                    # outer (active-set / Newton) iterations
    linear: int                   # inner linear iterations or CG iterations
    residual: float               # relative complementarity residual
    history: tuple                # residual history
    slack: float = 0.0            # Σ p g over S before g is set to 0 there (all ranks): what an
                                  # inexact solve leaves of complementarity (0 for an exact one)


@dataclass(frozen=True)
class NormalResult:
    """The converged state of one normal contact solve.

    Fields are (nx, ny) arrays on the topography's grid, identical on every
    rank, zero (``gap``: NaN) outside the footprint; or, for a solve asked for
    ``gather=False``, each rank's own grid rows ``rows`` = (start, stop) of
    them, (stop − start, ny), so that no rank holds N values (gather them with
    :func:`~.fields.gather_result`, write them with
    :func:`~.fields.write_result`). Scalars are the same on every rank either
    way, but for ``elapsed``, each rank's own wall time. Forces are the nodal resultants p̄ of Eq. 9 (N); ``pressure`` is
    p̄ / s² (Pa). Coordinates (``centroid``) are in the grid's
    frame (node (i, j) at (i s, j s)); moments are about the footprint's
    centroid ``reference_point``.
    """

    force: np.ndarray
    pressure: np.ndarray
    contact: np.ndarray
    gap: np.ndarray
    load: float
    moments: tuple[float, float]
    centroid: tuple[float, float]
    reference_point: tuple[float, float]
    closure: float
    rotation: tuple[float, float]
    contact_area: float
    nominal_area: float
    outer_iterations: int
    linear_iterations: int
    residual: float
    elapsed: float
    solver: str
    control: str
    no_contact: bool
    full_contact: bool
    operator: str = "dense"
    method: str = ""
    choice: str = ""
    coarse_iterations: int = 0
    converged: bool = True
    reason: str = "CONVERGED"
    residual_history: tuple[float, ...] = field(default_factory=tuple)
    rows: tuple[int, int] | None = None
    contact_nodes: int = -1

    @property
    def distributed(self) -> bool:
        """The fields are this rank's grid rows only (a solve with ``gather=False``)."""
        return self.rows is not None

    def require_whole(self, parameter: str = "normal") -> None:
        """:class:`InputError` if the fields are one rank's rows: what needs the whole grid on
        every rank (tangential solves, datasets, analysis) cannot take this result."""
        if self.rows is not None:
            raise InputError(parameter, f"holds only this rank's grid rows {self.rows[0]}:{self.rows[1]} "
                                        "(solved with gather=False); gather it first with "
                                        "roughcontact.normal.gather_result(result, problem)")

    @property
    def contact_fraction(self) -> float:
        """Real over apparent contact area A_r / A_0."""
        return self.contact_area / self.nominal_area

    @property
    def contact_count(self) -> int:
        """Nodes in contact (all ranks)."""
        return self.contact_nodes if self.contact_nodes >= 0 else int(self.contact.sum())

    def summary(self) -> str:
        flags = [f for f, on in (("no contact", self.no_contact), ("full contact", self.full_contact)) if on]
        return (f"P={self.load:.6g} N, δz={self.closure:.6g} m, θ=({self.rotation[0]:.3g}, "
                f"{self.rotation[1]:.3g}), A_r/A_0={self.contact_fraction:.4f}, "
                f"outer={self.outer_iterations}, linear={self.linear_iterations}, "
                f"residual={self.residual:.2e}, {self.elapsed:.3f} s"
                + (f" [{', '.join(flags)}]" if flags else ""))
