"""Which footprint nodes each rank owns: the nodes of its block of grid rows.

The unknowns of every operator are the footprint nodes in C order of the
mask (``numpy.argwhere(footprint)``). Rank r owns the nodes of grid rows
[row_start, row_stop) given by :func:`~roughcontact.surfaces.rows.split` (nx, ranks): a
contiguous range of unknowns, and exactly the rows of the slab that the FFT
convolution transforms on that rank, so a distributed vector maps to the
rank's slab of the grid without communication. Both operators use this
layout, so results do not depend on which operator solved them.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ..errors import InputError
from ..surfaces.rows import gather_into, split


@dataclass(frozen=True)
class NodeLayout:
    """This rank's share of the footprint nodes.

    Attributes
    ----------
    shape
        (nx, ny) of the grid.
    local_mask
        The footprint on this rank's rows, (rows, ny).
    rows
        (row_start, row_stop): the grid rows of this rank.
    start, stop
        Global indices of the owned unknowns.
    size
        Number of footprint nodes (all ranks).
    footprint
        The (nx, ny) mask of all nodes, or None where the topography is held by rows
        (:class:`~roughcontact.surfaces.TopographyRows`): only the dense operator's assembly
        needs it, and gathers it (:meth:`with_footprint`).
    """

    shape: tuple[int, int]
    local_mask: np.ndarray
    rows: tuple[int, int]
    start: int
    stop: int
    size: int
    footprint: np.ndarray | None = None

    @classmethod
    def build(cls, topography, comm) -> "NodeLayout":
        """The layout of a :class:`~roughcontact.surfaces.Topography` (whole on every rank) or a
        :class:`~roughcontact.surfaces.TopographyRows` (this rank's rows) on ``comm``."""
        shape = tuple(topography.shape)
        r0, r1 = split(shape[0], comm.Get_size())[comm.Get_rank()]
        if topography.by_rows and not all(comm.allgather(tuple(topography.rows) == (r0, r1))):
            raise InputError("topography", f"holds rows split over another number of ranks than the "
                                           f"communicator's {comm.Get_size()}")
        per_row = np.asarray(topography.row_counts)
        start = int(per_row[:r0].sum())
        return cls(shape=shape, local_mask=np.asarray(topography.local_rows((r0, r1))[1], dtype=bool),
                   rows=(r0, r1), start=start, stop=start + int(per_row[r0:r1].sum()), size=int(per_row.sum()),
                   footprint=None if topography.by_rows else np.asarray(topography.footprint, dtype=bool))

    def with_footprint(self, comm) -> "NodeLayout":
        """The same layout holding the whole footprint (collective: gathered from every rank's rows)."""
        if self.footprint is not None:
            return self
        counts = [(b - a) * self.shape[1] for a, b in comm.allgather(self.rows)]
        return replace(self, footprint=gather_into(comm, self.local_mask, counts, self.shape))

    @property
    def local_size(self) -> int:
        return self.stop - self.start

    @cached_property
    def whole_rows(self) -> bool:
        """Every node of this rank's rows is in the footprint: vectors are the slab, reshaped."""
        return bool(self.local_mask.all())

    @cached_property
    def whole_grid(self) -> bool:
        """Every node of the grid is in the footprint."""
        return self.size == self.shape[0] * self.shape[1]

    @cached_property
    def positions(self) -> np.ndarray:
        """Flat slab position of each owned node."""
        return np.flatnonzero(self.local_mask)

    def slab_positions(self, nodes: np.ndarray) -> np.ndarray:
        """Flat slab positions of this rank's nodes ``nodes`` (local indices): ``nodes`` itself
        where the rows are whole (the positions are then 0, 1, 2, …), instead of a gather that
        took 8 ms an iteration, three times, near full contact at 2048²."""
        return nodes if self.whole_rows else self.positions[nodes]

    def to_slab(self, values: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """This rank's rows of the grid with ``values`` (owned nodes) on the footprint, 0 elsewhere
        (a view of ``values`` when the rows are whole)."""
        mask = self.local_mask
        if self.whole_rows:
            return np.asarray(values).reshape(mask.shape)
        if out is None:
            out = np.zeros(mask.shape)
        else:
            out.fill(0.0)
        out[mask] = values
        return out

    def from_slab(self, slab: np.ndarray) -> np.ndarray:
        """The owned nodes' values of a slab field (a view when the rows are whole)."""
        if self.whole_rows:
            return slab.reshape(-1)
        return slab[self.local_mask]

    def index_sums(self) -> np.ndarray:
        """(Σ i, Σ j) over this rank's nodes (int64, exact): from the mask's counts per row and per
        column, not from the nodes' indices, whose array took 0.39 s to make at 2048²."""
        mask = self.local_mask
        return np.array([mask.sum(axis=1, dtype=np.int64) @ np.arange(*self.rows, dtype=np.int64),
                         mask.sum(axis=0, dtype=np.int64) @ np.arange(self.shape[1], dtype=np.int64)])

    def parities(self) -> np.ndarray:
        """(i + j) mod 2 of each of this rank's nodes, as a bool (the colour of the node on the
        grid's checkerboard, the same on any number of ranks): i + j is odd where the parities of
        i and j differ, one byte per node of the slab and no wider temporary."""
        rows = np.arange(*self.rows) % 2 == 1
        board = np.not_equal(rows[:, None], np.arange(self.shape[1]) % 2 == 1)
        return board.reshape(-1) if self.whole_rows else board[self.local_mask]

    def local_nodes(self) -> np.ndarray:
        """(i, j) grid indices of this rank's nodes, in the order of the unknowns (int32: a grid
        has fewer than 2³¹ rows and columns)."""
        nodes = np.argwhere(self.local_mask).astype(np.int32)
        nodes[:, 0] += self.rows[0]
        return nodes

