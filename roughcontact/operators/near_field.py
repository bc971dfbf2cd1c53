"""The near field of a few nodal forces, summed directly: H c within R nodes of each force.

The constrained CG (:mod:`roughcontact.normal.constrained_cg`) cuts the
forces that a step would make negative and must add H c, the displacement
of the forces c the cut restores, to its updated H p. Late in a solve c
sits on a handful of nodes and is small, yet each cut cost a whole padded
FFT product. Here H c is split at a radius of R nodes:

- the near part, every node (i, j) with |Δi| ≤ R and |Δj| ≤ R of a force,
  is summed directly from the (2R + 1)² window of the Eq. 10 table, a few
  microseconds per force;
- the far part of each force is at most ``far_bound`` × force at every node
  (the kernel decreases with the distance, and every node outside the window
  is at least R + 1 spacings away: K(R + 1, 0) = A/(2πa) arcsin(a / ((R + 1) s)),
  about 1/(π (R + 1)) of the diagonal A/(4a)).

The far parts of the forces can therefore wait and be added later by one
FFT product of all of them together, less their near parts
(:meth:`NearField.add` with ``sign = -1``), once their bound matters for the
residual. It applies to the half-space FFT operator on a footprint that is
the whole grid (vectors are the slab itself, no window wraps round).
"""
from __future__ import annotations

import numpy as np

from .kernel import mirrored_kernel, punch_kernel

#: nodes of the window's half-width: K(R + 1, 0) is 0.0096 of the diagonal at 32, and a window
#: of 65 × 65 values costs about 10 µs per force
NEAR_RADIUS = 32
#: the sets of a settled product are merged through a mask of the rank's nodes where together
#: they hold more than one index in this many (:func:`_union`), else by np.unique
UNION_MASK = 64


class NearField:
    """Direct sums of the Eq. 10 kernel within ``radius`` nodes of given forces, on the slab
    layout of a :class:`~.flexibility.Flexibility` (whole-grid footprint, half-space operator)."""

    def __init__(self, flexibility, radius: int = NEAR_RADIUS):
        self.radius = int(radius)
        self.comm = flexibility.comm
        self.shape = flexibility.shape
        self.rows = flexibility.layout.rows
        self.slab_positions = flexibility.layout.slab_positions
        reach = self.radius + 1
        table = punch_kernel((reach + 1, reach), flexibility.spacing, flexibility.compliance)
        self.window = mirrored_kernel(table[:reach])                               # (2R + 1)²
        #: the largest kernel value outside the window: K(R + 1, 0)
        self.far_bound = float(table[reach, 0])

    @staticmethod
    def applies(flexibility) -> bool:
        """Whether a near field can stand in for part of the operator's products (the same on
        every rank): the half-space FFT operator on a whole-grid footprint."""
        return (flexibility.convolution is not None and not flexibility.periodic
                and flexibility.layout.whole_grid)

    def add(self, out: np.ndarray, nodes: np.ndarray, forces: np.ndarray, sign: float = 1.0) -> None:
        """out += sign · (near part of H c), c the ``forces`` on this rank's ``nodes`` (local
        indices), ``out`` this rank's nodal vector; collective: every rank adds the windows of
        every rank's forces that reach its rows."""
        ny = self.shape[1]
        field = out.reshape(self.rows[1] - self.rows[0], ny)
        r0, r1 = self.rows
        reach, window = self.radius, self.window
        for block in gathered_centres(self.comm, self.rows, ny, self.slab_positions(nodes), forces):
            for row, column, force in block:
                row, column = int(row), int(column)
                top, bottom = max(row - reach, r0), min(row + reach + 1, r1)
                if top >= bottom:
                    continue
                left, right = max(column - reach, 0), min(column + reach + 1, ny)
                part = window[top - row + reach:bottom - row + reach, left - column + reach:right - column + reach]
                field[top - r0:bottom - r0, left:right] += (sign * force) * part


def gathered_centres(comm, rows: tuple[int, int], ny: int, positions: np.ndarray, values) -> list[np.ndarray]:
    """(grid row, grid column, value) of this rank's slab ``positions`` (on ``rows`` of a grid
    ``ny`` wide) and of every other rank's, one (K, 3) block per rank; collective."""
    mine = np.column_stack([positions // ny + rows[0], positions % ny, values])
    return comm.allgather(mine) if comm.Get_size() > 1 else [mine]


class PendingFarField:
    """Forces whose near field is in a displacement vector and whose far field is not yet.

    The constrained CG defers the far field of the forces its cuts restore while
    ``far_bound`` × their sum, the most their far fields can add to any node, stays
    below a share of its residual, and settles them all with one product when a cut
    would pass that bound (:meth:`settle`). ``mass`` and ``count`` are over all ranks.
    """

    def __init__(self, near: NearField):
        self.near = near
        self.entries: list[tuple[np.ndarray, np.ndarray]] = []
        self.mass = 0.0
        self.count = 0

    def bound(self, mass: float = 0.0) -> float:
        """The most the deferred far fields, and those of ``mass`` more, add to any node."""
        return self.bound_of(self.mass + mass)

    def bound_of(self, mass: float) -> float:
        """The most the far fields of forces of sum ``mass`` alone add to any node."""
        return self.near.far_bound * mass

    def defer(self, displacement: np.ndarray, nodes: np.ndarray, forces: np.ndarray,
              mass: float, count: int) -> None:
        """Add the near field of ``forces`` on this rank's ``nodes`` to ``displacement`` and keep
        them (their sum ``mass`` and number ``count`` over all ranks); collective."""
        self.near.add(displacement, nodes, forces)
        self.entries.append((nodes.copy(), forces.copy()))
        self.mass += mass
        self.count += count

    def rescale(self, factor: float) -> None:
        """The forces were scaled by ``factor`` (the CG restoring the load), their fields with them."""
        for _, forces in self.entries:
            forces *= factor
        self.mass *= factor

    def settle(self, clipped: np.ndarray, nodes: np.ndarray, product) -> np.ndarray:
        """H (clipped + deferred) less the deferred forces' near field, which the displacement
        already holds: what completes it. ``clipped`` (this rank's nodal vector) is zero but at
        this rank's ``nodes`` (a cut's, the step's and its cut's, or none); it gets the deferred
        forces for the product and loses them after. ``product(clipped, every)`` is H of
        ``clipped``, which is zero off the nodes ``every`` (``nodes`` and the deferred ones;
        :meth:`~.flexibility.Flexibility.product_at` of ``clipped[every]`` takes only those
        nodes into the transform). Collective."""
        for where, forces in self.entries:
            clipped[where] += forces
        every = _union([nodes, *(where for where, _ in self.entries)], clipped.size)
        field = product(clipped, every)
        for where, forces in self.entries:
            clipped[where] = 0.0           # the caller zeroes ``nodes`` after anyway
            self.near.add(field, where, forces, -1.0)
        self.clear()
        return field

    def clear(self) -> None:
        """Forget the deferred forces: the displacement was computed again from the forces."""
        self.entries.clear()
        self.mass = 0.0
        self.count = 0


def _union(sets: list[np.ndarray], size: int) -> np.ndarray:
    """The sorted union of index ``sets`` into a vector of ``size``: np.unique of their
    concatenation where they are small, a mask where they hold more than one index in
    UNION_MASK (near full contact at 2048² np.unique took 0.68 s for the 78 merges of a solve,
    the mask 0.16 s; a mask's pass over the rank's nodes costs the same whatever the sets)."""
    if sum(indices.size for indices in sets) * UNION_MASK <= size:
        return np.unique(np.concatenate(sets))
    marked = np.zeros(size, dtype=bool)
    for indices in sets:
        marked[indices] = True
    return np.flatnonzero(marked)
