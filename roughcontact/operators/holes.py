"""The holes of a contact set, and the edge charge they let the preconditioner take back.

The edge correction (:mod:`.preconditioner`) removes a share of κ_i, the
charge Σ_{j∉S} (−A_ij) that R_S C⁻¹ R_Sᵀ puts on node i of the set S for the
nodes outside it (A = C⁻¹), and leaves the rest, r_i = (1 − share) ·
min(max(κ_i, 0), cap · A_ii) = e_i (1 − share) / share, so that isolated
nodes keep a scaling. Near full contact the outside is a dust of holes
enclosed by contact, and for a field u smooth across a hole H_SS⁻¹ charges
nothing there: its quadratic form is that of C⁻¹ on the cheapest extension
of u into the hole, which fills it. The charge left on every hole's rim then
adds up over the grid: on the solved set of Δ = 2.5 at 1 E*
(benchmarks/bench_deflation.py) the largest Ritz value of the corrected
M H_SS was 6.45 / 11.6 / 23.0 at 512² / 1024² / 2048², its mode of one sign
with 93 % of its energy on nodes next to a hole (the constant field's
Rayleigh quotient alone was 4.95 at 512²). Around an island the outside is
the open sea, and the same field pays for it (the island is a punch).

A hole here is a component of the outside (4-neighbours) that does not
touch the grid's frame: beyond the frame a bounded grid is free surface, so a
component that reaches it is open (:func:`enclosed`). The rims of the holes
are the nodes of S within RIM of a hole and not within RIM of the open
outside or of the frame, and r^h is r on the rims, 0 elsewhere. On square
blocks (HOLE_BLOCK = 64 nodes a side up to 2048², :func:`block_side`) the
preconditioner takes back, for the field constant on the block's nodes of
S, the charge left on the rims:

    M' = M − Σ_b r^h_b r^h_bᵀ / (1ᵀ r^h_b).

Each term is a rank-one matrix; by Cauchy–Schwarz (r^h_bᵀ u)² ≤ (1ᵀ r^h_b)
Σ r^h_i u_i², so uᵀ M' u ≥ uᵀ (M − diag(r)) u, the full-share preconditioner
capped at EDGE_CAP, which stays positive definite wherever the difference
part is (:mod:`.preconditioner`). One application costs a sum of r^h ∘ g per
block and one reduction of the block sums over the ranks; the rims cost a
labelling of the outside and two square filters of the slab, made again when
the edge weights take a product.

Measured on the solved sets (fixed-set PCG to 1e-8, Ritz range after 60
Lanczos steps; near full contact at 512² / 1024² / 2048² 19 / 23 / 30
iterations (0.46–6.45, 0.44–11.6, 0.45–23.0) before; the large-grid scene
(0.01 E*, islands in an open sea) 12 / 15 / 18 / 24 at 512² to 4096²):

- the rims with RIM = 1: near full contact 16 at 1024² (0.36–3.93); the
  scene 22 at 4096² (0.39–5.07); RIM = 2: 16 (0.31–2.82) and 24 (0.34–4.89);
- every node of a block, in the share γ_b of the block's outside that lies
  in holes: near full contact 14 / 15 / 16 (0.38–1.32, 0.30–1.42,
  0.32–1.92), but the scene 28 at 4096² (0.28–5.29): at that resolution
  17 blocks of islands hold holes, and the charge of their sea edges was
  taken back with the holes'; with γ_b = 1 on every block the scene's
  smallest Ritz value fell from 0.40 to 0.07 at 512² (26 against 12);
- every node not within RIM of the open outside: near full contact 15
  (0.30–1.35) at 1024², the scene 20 at 2048² (0.26–2.46): the interiors of
  islands;
- blocks of 32 or 128 took 1–2 more iterations than 64; one block over the
  grid took the top near full contact at 512² from 6.45 to 3.22 only: the
  field that pays too much is constant on patches of holes, not over the
  grid.

Where the outside is a dust of holes (near full contact: holes hold at
least DUST = 1/2 of the outside over the whole grid), a block whose outside
is at least DUST holes takes the charge back on every node of S in that
share γ_b, r^h = γ_b r, and the other blocks on their rims as above (the
second form of the list, kept where it pays). With the blocks' rule
alone, on every set, it cost the large-grid scene at 4096² 4 fine
iterations in the solve (35 against 31; 33 without the nodes next to the
open outside, 34 with the blocks' threshold at 0.9): its blocks inside
large islands that enclose holes have γ_b near 1 too. The scene's outside
is an open sea, which keeps it below the switch on the whole grid. Whole
solves (one rank, fine iterations), rims alone → with the dust: near full
contact (Δ = 2.5, 1 E*) 256² / 512² / 1024² / 2048² / 4096² 18 / 22 / 29 /
37 / 52 → 19 / 21 / 27 / 34 / 48; the scene 14 / 15 / 17 / 21 / 31 both
(docs/solver-cost.md, "The hole charge on a dust of holes"). There r^h is
kept on every node of S by runs of nodes in one row of one block
(:class:`_Runs`), so that the subtraction gathers and scatters nothing.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..surfaces.rows import padded_rows
from .set_blocks import held_for_set, set_sized

#: the side of the blocks on which the hole charge is taken back (nodes), on grids of up to
#: HOLE_SPAN × HOLE_BLOCK nodes a side
HOLE_BLOCK = 64
#: above that, the blocks' side is the grid's longer side over HOLE_SPAN (:func:`block_side`)
HOLE_SPAN = 32
#: the rims of holes: the nodes within this many (a square) of a hole and not of the open outside
RIM = 1
#: the outside is a dust of holes (near full contact) where holes hold at least this share of it
#: over the whole grid; then a block whose outside is at least this share holes, γ_b, takes the
#: charge back on all its nodes of S in that share, the others on their rims
DUST = 0.5
#: the runs a spread repeats at a time (its temporary: at most this many blocks' rows)
RUNS_CHUNK = 1024


def block_side(shape: tuple[int, int]) -> int:
    """The side of the hole charge's blocks on a grid of ``shape``: HOLE_BLOCK, or the longer
    side over HOLE_SPAN where that is more (128 at 4096²). The range of scales over which holes
    gather into patches grows with the grid; whole solves at 4096² (one rank, fine iterations,
    blocks of 64 → this rule, its 2048² coarse level on 64): the large-grid scene, three surfaces,
    31 / 31 / 25 → 29 / 30 / 25, near full contact (Δ = 2.5, 1 E*), two surfaces, 48 / 50 → 47 /
    48; at 1024² and 2048² blocks of 128 took the same or one more (docs/solver-cost.md, "The
    hole charge's blocks grow with the grid")."""
    return max(HOLE_BLOCK, max(shape) // HOLE_SPAN)


def enclosed(outside: np.ndarray, comm, first_row: int, rows_total: int) -> np.ndarray:
    """The nodes of ``outside`` (this rank's (rows, ny) slab of the nodes outside the set, its
    first grid row ``first_row`` of ``rows_total``) whose component of the outside (4-neighbours,
    over all ranks) touches no edge of the grid; collective."""
    labels, count = ndimage.label(outside)
    offset = comm.exscan(count) or 0
    rows, ny = outside.shape
    # the components on the grid's frame, and the labels of the slab's first and last rows,
    # as global ids (0: not outside); only those lines are read, not the whole slab's labels
    def ids(line: np.ndarray) -> np.ndarray:
        return np.where(line > 0, line + offset, 0)

    ends = (ids(labels[0]), ids(labels[-1])) if rows else None
    frame = [ids(labels[:, 0]), ids(labels[:, -1])] if rows and ny else []
    if rows and first_row == 0:
        frame.append(ends[0])
    if rows and first_row + rows == rows_total:
        frame.append(ends[1])
    touching = np.unique(np.concatenate(frame)) if frame else np.zeros(0, dtype=labels.dtype)
    gathered = comm.allgather((touching[touching > 0], ends))
    # components that run across the boundary between two consecutive non-empty slabs are one
    slabs = [part[1] for part in gathered if part[1] is not None]
    pairs = [np.stack([below[0][both], above[1][both]]) for above, below in zip(slabs, slabs[1:])
             for both in [(above[1] > 0) & (below[0] > 0)]]
    links = np.concatenate(pairs, axis=1) if pairs else np.zeros((2, 0), dtype=labels.dtype)
    open_ids = np.concatenate([part[0] for part in gathered])
    involved = np.unique(np.concatenate([links.ravel(), open_ids]))
    if involved.size:
        a, b = np.searchsorted(involved, links)
        graph = coo_matrix((np.ones(a.size), (a, b)), shape=(involved.size,) * 2)
        _, component = connected_components(graph, directed=False)
        open_components = np.zeros(component.max() + 1, dtype=bool)
        open_components[component[np.searchsorted(involved, open_ids)]] = True
        mine = (involved > offset) & (involved <= offset + count)
        is_open = np.zeros(count + 1, dtype=bool)
        is_open[involved[mine] - offset] = open_components[component[mine]]
    else:
        is_open = np.zeros(count + 1, dtype=bool)
    is_open[0] = True                                   # label 0: inside the set
    return ~is_open[labels]


class HoleCharge:
    """M' = M − Σ_b r^h_b r^h_bᵀ / (1ᵀ r^h_b), r^h the charge left on the rims of holes (or, where
    the outside is a dust of holes, on the dust blocks' nodes in the share γ_b), on a free set
    that changes from one call to the next (module docstring); the layout of a
    :class:`~.flexibility.Flexibility`."""

    def __init__(self, layout, comm, share: float, block: int | None = None):
        self.layout, self.comm = layout, comm
        self.factor = (1.0 - share) / share             # r = e · factor
        nx, ny = layout.shape
        self.block = block_side(layout.shape) if block is None else block
        self.grid = (-(-nx // self.block), -(-ny // self.block))  # blocks per direction
        self.count = self.grid[0] * self.grid[1]        # blocks
        self.rim = np.zeros(0, dtype=bool)              # the rims of holes, over this rank's slab
        # γ_b where a block takes the charge on all its nodes of S (0: on its rims), None: rims only
        self.dust: np.ndarray | None = None
        # r^h, by runs of nodes in one row of one block (the nodes are in slab order), so that no
        # node holds its block's index: on the nodes of S on a rim alone, or on every node of S
        # where the outside is a dust of holes
        self.on_rim: np.ndarray | None = np.zeros(0, dtype=np.intp)   # their places in S (None: all)
        self.charge = np.zeros(0)                       # r^h there
        self.runs = _Runs.empty()                       # their runs
        self.inverse = np.zeros(self.count)             # 1 / (1ᵀ r^h_b), 0 where a block has none
        self.active = False                             # whether any block takes charge back
        self.labelled = False                           # whether the rims have been found

    def relabel(self, members: np.ndarray) -> None:
        """The rims of the holes of the free set given as the mask ``members`` over this rank's
        nodes: the nodes within RIM of a hole and not within RIM of the open outside or of the
        grid's frame (beyond it the outside is open); and, where the holes hold at least DUST of
        the outside over the whole grid, the blocks whose outside is at least DUST holes and
        their share γ_b; collective."""
        nx, ny = self.layout.shape
        r0, r1 = self.layout.rows
        if self.layout.whole_rows:                      # the nodes are the slab's positions in order
            outside = np.logical_not(members)
        else:
            outside = np.ones((r1 - r0) * ny, dtype=bool)
            outside[self.layout.positions[members]] = False
        outside = outside.reshape(r1 - r0, ny)
        holes = enclosed(outside, self.comm, r0, nx)
        near_hole = _near(holes, self.comm, r0, nx, beyond=False)
        near_open = _near(outside & ~holes, self.comm, r0, nx, beyond=True)
        self.rim = (near_hole & ~near_open).reshape(-1)
        counts = self.comm.allreduce(np.concatenate([self._block_counts(outside), self._block_counts(holes)]))
        out_b, holes_b = counts[:self.count], counts[self.count:]
        self.dust = None
        if holes_b.sum() >= DUST * out_b.sum() > 0:
            share = np.divide(holes_b, out_b, out=np.zeros(self.count), where=out_b > 0)
            self.dust = np.where(share >= DUST, share, 0.0)
        self.labelled = True

    def _block_counts(self, field: np.ndarray) -> np.ndarray:
        """The True nodes of this rank's (rows, ny) slab ``field`` in each block (float64)."""
        out = np.zeros(self.count)
        rows = field.shape[0]
        if rows == 0:
            return out
        block_rows = (self.layout.rows[0] + np.arange(rows)) // self.block
        starts = np.flatnonzero(np.diff(block_rows, prepend=-1))
        # within each row first, over contiguous runs of bytes, then over the block's rows: the
        # rows first (the bool slab widened to int64) took 23 ms where this takes 2.3 ms for a
        # 2048² slab on one rank
        sums = np.add.reduceat(np.add.reduceat(field.view(np.uint8), np.arange(0, field.shape[1], self.block),
                                               axis=1, dtype=np.int32), starts, axis=0)
        out[(block_rows[starts][:, None] * self.grid[1] + np.arange(self.grid[1])).reshape(-1)] = sums.reshape(-1)
        return out

    def update(self, nodes: np.ndarray, edge: np.ndarray) -> None:
        """The charge on the free set given by this rank's node indices and its edge weights
        ``edge`` (on the same nodes); collective."""
        positions = self.layout.slab_positions(nodes)
        self.charge = self.runs = None                  # the last set's, let go before the new are made
        if self.dust is None:
            # only the rims' nodes carry charge: near full contact at 2048² the blocks and scales
            # of every node of S took 59 ms an update and the block sums 27 ms a subtraction
            self.on_rim = np.flatnonzero(self.rim[positions])
            self.charge = edge[self.on_rim] * self.factor
            self.runs = _Runs.of(positions[self.on_rim], self.layout, self.block, self.grid)
        else:
            # a dust of holes: nearly every node of S carries charge, and all of them are kept (a
            # weight of 0 where a block that takes it on its rims has a node off them), so that
            # the subtraction needs no gather and no scatter of the set's values
            # (built in place: temporaries of 8 B per node raised the peak near full contact)
            self.on_rim = None
            self.runs = _Runs.of(positions, self.layout, self.block, self.grid)
            # γ_b, or 0 on the blocks on their rims
            self.charge = self.runs.spread(self.dust, held_for_set(positions.size))
            np.copyto(self.charge, self.rim[positions], where=self.charge == 0.0)
            self.charge *= edge
            self.charge *= self.factor
        totals = self.comm.allreduce(self.runs.block_sums(self.charge, self.count))
        self.inverse = np.divide(1.0, totals, out=np.zeros_like(totals), where=totals > 0)
        self.active = bool(np.any(totals > 0))

    def subtract(self, g: np.ndarray, z: np.ndarray) -> None:
        """z −= Σ_b r^h_b (r^h_bᵀ g) / (1ᵀ r^h_b) on the free set of the last :meth:`update`;
        collective."""
        if not self.active:
            return
        on = g if self.on_rim is None else g[self.on_rim]
        charged = np.multiply(self.charge, on, out=set_sized(on.size))
        sums = self.comm.allreduce(self.runs.block_sums(charged, self.count))
        del charged
        taken = self.runs.spread(sums * self.inverse)
        taken *= self.charge
        if self.on_rim is None:
            z -= taken
        else:
            z[self.on_rim] -= taken


class _Runs:
    """Nodes in slab order cut into runs that lie in one row of one block: each run's first place,
    its length and its block. A block's sum is its runs' sums (``numpy.add.reduceat``), and a
    value per block is spread back over its nodes run by run (``numpy.repeat``): near full
    contact at 2048² the blocks' indices of 3.6 M nodes took 52 ms to make and 17 ms to sum by
    (``numpy.bincount``), the runs 3 ms to sum by."""

    def __init__(self, starts: np.ndarray, lengths: np.ndarray, blocks: np.ndarray):
        self.starts, self.lengths, self.blocks = starts, lengths, blocks

    @classmethod
    def empty(cls) -> "_Runs":
        return cls(np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp))

    @classmethod
    def of(cls, positions: np.ndarray, layout, block: int, grid: tuple[int, int]) -> "_Runs":
        """The runs of the ascending flat slab ``positions`` on ``layout``'s rows (one search per
        row and block column, none per node); runs without nodes are dropped."""
        r0, r1 = layout.rows
        ny = layout.shape[1]
        rows = np.arange(r1 - r0)
        firsts = (rows[:, None] * ny + np.arange(0, ny, block)[None, :]).reshape(-1)
        starts = np.searchsorted(positions, firsts)
        lengths = np.diff(starts, append=positions.size)
        blocks = (((r0 + rows) // block)[:, None] * grid[1] + np.arange(grid[1])[None, :]).reshape(-1)
        kept = lengths > 0
        return cls(starts[kept], lengths[kept], blocks[kept])

    def block_sums(self, values: np.ndarray, count: int) -> np.ndarray:
        """The sum of ``values`` (one per node of the runs) on each of ``count`` blocks (float64)."""
        if self.starts.size == 0:
            return np.zeros(count)
        return np.bincount(self.blocks, weights=np.add.reduceat(values, self.starts), minlength=count)

    def spread(self, per_block: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``per_block``'s value of each node's block, node by node: a new array, or into ``out``
        (as long as the runs together; they tile it) RUNS_CHUNK runs at a time, for a block that
        is kept (``numpy.repeat`` has no ``out``; the chunks' copy costs a pass: 4.8–5.0 against
        2.4–2.6 ms for 3.4 M nodes, so a subtraction's spread, made at every iteration, stays
        whole)."""
        values = per_block[self.blocks]
        if out is None:
            return np.repeat(values, self.lengths)
        count, chunk = self.starts.size, RUNS_CHUNK
        for a in range(0, count, chunk):
            b = min(a + chunk, count)
            stop = self.starts[b] if b < count else out.size
            out[self.starts[a]:stop] = np.repeat(values[a:b], self.lengths[a:b])
        return out


def _near(field: np.ndarray, comm, first_row: int, rows_total: int, beyond: bool) -> np.ndarray:
    """The nodes of this rank's (rows, ny) slab within RIM nodes (a square) of a True node of
    ``field`` over all ranks (rows ``first_row`` on of ``rows_total``); ``beyond``: the nodes past
    the grid's edges count as True; collective (the RIM rows beyond the slab's ends come from
    the ranks that hold them, :func:`~roughcontact.surfaces.rows.rows_window`)."""
    rows, ny = field.shape
    # rows and columns past the grid keep ``beyond``
    window = padded_rows(field, (first_row, first_row + rows), rows_total, RIM, beyond, comm)
    # the square's maximum as ORs of shifted views, along y and then x: scipy's maximum_filter
    # took 115 ms a call on a 4096² slab, 1.8 s of the large-grid scene's solve
    across = window[:, :ny].copy()
    for shift in range(1, 2 * RIM + 1):
        across |= window[:, shift:shift + ny]
    grown = across[:rows].copy()
    for shift in range(1, 2 * RIM + 1):
        grown |= across[shift:shift + rows]
    return grown
