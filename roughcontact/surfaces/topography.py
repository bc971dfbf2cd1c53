"""The composite topography on a square grid, the input of every contact solve.

Conventions (used throughout the package)
-----------------------------------------
- ``heights[i, j]`` is the composite height Δh at node (i, j), located at
  x = i s, y = j s (axis 0 is x, axis 1 is y), in metres. Larger heights
  protrude further towards the counter-face: the highest node touches first.
- The grid is square with spacing ``s`` (m): each node is the centre of a
  rigid circular punch of radius s/2 (paper, §3.1, Eq. 10).
- ``footprint`` is a boolean mask of the nodes that belong to the nominal
  contact region; heights outside it are ignored (and may be NaN).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..checks import require_finite_positive
from ..errors import InputError


@dataclass(frozen=True)
class Topography:
    """Heights on a square grid with a footprint mask.

    Parameters
    ----------
    heights
        2-D array (nx, ny) of composite heights in metres.
    spacing
        Grid spacing s in metres (a single number: the grid is square). A pair
        (sx, sy) is accepted only when sx == sy.
    footprint
        Boolean mask (nx, ny) of the nominal contact region; default all nodes.
    metadata
        Free-form provenance (instrument, units read, generator parameters).
    """

    heights: np.ndarray
    spacing: float
    footprint: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    #: whole on every rank (a :class:`~.rows.TopographyRows` holds one rank's rows)
    by_rows: ClassVar[bool] = False

    def __post_init__(self):
        heights = np.asarray(self.heights, dtype=float)
        if heights.ndim != 2:
            raise InputError("heights", f"must be a 2-D array, got {heights.ndim} dimension(s)")
        if heights.shape[0] < 1 or heights.shape[1] < 1:
            raise InputError("heights", f"is empty (shape {heights.shape})")
        spacing = _square_spacing(self.spacing)
        if self.footprint is None:
            footprint = np.ones(heights.shape, dtype=bool)
        else:
            footprint = np.asarray(self.footprint)
            if footprint.shape != heights.shape:
                raise InputError("footprint", f"shape {footprint.shape} differs from heights {heights.shape}")
            footprint = footprint.astype(bool)
        if not footprint.any():
            raise InputError("footprint", "is empty: no node belongs to the nominal contact region")
        require_finite_heights(heights, footprint)
        heights = heights.copy()
        heights.setflags(write=False)
        footprint = footprint.copy()
        footprint.setflags(write=False)
        object.__setattr__(self, "heights", heights)
        object.__setattr__(self, "spacing", spacing)
        object.__setattr__(self, "footprint", footprint)
        object.__setattr__(self, "metadata", dict(self.metadata))

    @classmethod
    def from_coordinates(cls, x, y, heights, footprint=None, metadata=None,
                         rtol: float = 1e-6) -> "Topography":
        """Build from node coordinates, checking the grid is uniform and square.

        ``x`` (nx,) and ``y`` (ny,) are the node coordinates in metres.
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        heights = np.asarray(heights, dtype=float)
        if heights.ndim != 2 or heights.shape != (x.size, y.size):
            raise InputError("heights", f"shape {heights.shape} does not match (len(x), len(y)) = {(x.size, y.size)}")
        sx = _uniform_step("x", x, rtol)
        sy = _uniform_step("y", y, rtol)
        if sx is None and sy is None:
            raise InputError("x", "a single node gives no spacing")
        sx = sy if sx is None else sx
        sy = sx if sy is None else sy
        if abs(sx - sy) > rtol * max(sx, sy):
            raise InputError(
                "spacing", f"the grid is not square (sx = {sx:g} m, sy = {sy:g} m); "
                "resample it to a square grid first")
        return cls(heights, sx, footprint, metadata or {})

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape

    @property
    def x(self) -> np.ndarray:
        """Node x coordinates (m), axis 0."""
        return np.arange(self.shape[0]) * self.spacing

    @property
    def y(self) -> np.ndarray:
        """Node y coordinates (m), axis 1."""
        return np.arange(self.shape[1]) * self.spacing

    @property
    def footprint_nodes(self) -> int:
        """Nodes of the footprint."""
        return int(self.footprint.sum())

    @property
    def row_counts(self) -> np.ndarray:
        """(nx,) footprint nodes of every grid row."""
        return self.footprint.sum(axis=1, dtype=np.int64)

    def local_rows(self, rows: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """(heights, footprint) of grid rows ``rows`` = (start, stop) (views)."""
        return self.heights[rows[0]:rows[1]], self.footprint[rows[0]:rows[1]]

    @property
    def nominal_area(self) -> float:
        """Apparent area A0 of the footprint, one s² per node (m²)."""
        return float(self.footprint.sum()) * self.spacing**2

    def with_footprint(self, footprint: np.ndarray) -> "Topography":
        """The same heights on another footprint."""
        return Topography(self.heights, self.spacing, footprint, self.metadata)


def require_finite_heights(heights: np.ndarray, footprint: np.ndarray) -> None:
    """InputError unless every height on the footprint is finite (heights elsewhere are ignored)."""
    bad = int((~np.isfinite(heights) & footprint).sum())
    if bad:
        raise InputError("heights", f"{bad} node(s) of the footprint are NaN or infinite; "
                                    "mask missing data out of the footprint or fill it before solving")


def _square_spacing(spacing) -> float:
    if np.ndim(spacing) == 0:
        return require_finite_positive("spacing", spacing)
    pair = np.asarray(spacing, dtype=float).ravel()
    if pair.size != 2:
        raise InputError("spacing", f"must be a number or a pair (sx, sy), got {spacing!r}")
    sx = require_finite_positive("spacing", pair[0])
    sy = require_finite_positive("spacing", pair[1])
    if abs(sx - sy) > 1e-9 * max(sx, sy):
        raise InputError("spacing", f"the grid is not square (sx = {sx:g} m, sy = {sy:g} m); "
                         "resample it to a square grid first")
    return sx


def _uniform_step(name: str, coords: np.ndarray, rtol: float) -> float | None:
    if coords.ndim != 1 or coords.size == 0:
        raise InputError(name, "must be a non-empty 1-D array of node coordinates")
    if coords.size == 1:
        return None
    steps = np.diff(coords)
    step = float(np.mean(steps))
    if not np.isfinite(step) or step <= 0:
        raise InputError(name, "coordinates must be finite and strictly increasing")
    if np.max(np.abs(steps - step)) > rtol * step:
        raise InputError(name, f"the grid is not uniform (steps from {steps.min():g} to {steps.max():g} m)")
    return step
