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
outside or of the frame, and r^h is r on the rims, 0 elsewhere. On blocks of
HOLE_BLOCK × HOLE_BLOCK nodes the preconditioner takes back, for the field
constant on the block's nodes of S, the charge left on the rims:

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
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..surfaces.rows import rows_window

#: the side of the blocks on which the hole charge is taken back (nodes)
HOLE_BLOCK = 64
#: the rims of holes: the nodes within this many (a square) of a hole and not of the open outside
RIM = 1


def enclosed(outside: np.ndarray, comm, first_row: int, rows_total: int) -> np.ndarray:
    """The nodes of ``outside`` (this rank's (rows, ny) slab of the nodes outside the set, its
    first grid row ``first_row`` of ``rows_total``) whose component of the outside (4-neighbours,
    over all ranks) touches no edge of the grid; collective."""
    labels, count = ndimage.label(outside)
    offset = comm.exscan(count) or 0
    rows, ny = outside.shape
    # the components on the grid's frame, and the labels of the slab's first and last rows,
    # as global ids (0: not outside)
    ids = np.where(labels > 0, labels + offset, 0) if rows else labels
    frame = [ids[:, 0], ids[:, -1]] if rows and ny else []
    if rows and first_row == 0:
        frame.append(ids[0])
    if rows and first_row + rows == rows_total:
        frame.append(ids[-1])
    touching = np.unique(np.concatenate(frame)) if frame else np.zeros(0, dtype=ids.dtype)
    ends = (ids[0], ids[-1]) if rows else None
    gathered = comm.allgather((touching[touching > 0], ends))
    # components that run across the boundary between two consecutive non-empty slabs are one
    slabs = [part[1] for part in gathered if part[1] is not None]
    pairs = [np.stack([below[0][both], above[1][both]]) for above, below in zip(slabs, slabs[1:])
             for both in [(above[1] > 0) & (below[0] > 0)]]
    links = np.concatenate(pairs, axis=1) if pairs else np.zeros((2, 0), dtype=ids.dtype)
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
    """M' = M − Σ_b r_b r_bᵀ / (1ᵀ r_b), r the charge left on the rims of holes, on a free set that
    changes from one call to the next (module docstring); the layout of a
    :class:`~.flexibility.Flexibility`."""

    def __init__(self, layout, comm, share: float, block: int = HOLE_BLOCK):
        self.layout, self.comm = layout, comm
        self.factor = (1.0 - share) / share             # r = e · factor
        self.block = block
        nx, ny = layout.shape
        self.grid = (-(-nx // block), -(-ny // block))  # blocks per direction
        self.count = self.grid[0] * self.grid[1]        # blocks
        self.rim = np.zeros(0, dtype=bool)              # the rims of holes, over this rank's slab
        # r^h is zero off the rims: the charge is kept on the nodes of S on a rim alone
        self.on_rim = np.zeros(0, dtype=np.intp)        # their places in S
        self.blocks = np.zeros(0, dtype=np.int32)       # their blocks
        self.scale = np.zeros(0)                        # r_i / (1ᵀ r_b) there
        self.charge = np.zeros(0)                       # r there
        self.active = False                             # whether any block takes charge back
        self.labelled = False                           # whether the rims have been found

    def relabel(self, members: np.ndarray) -> None:
        """The rims of the holes of the free set given as the mask ``members`` over this rank's
        nodes: the nodes within RIM of a hole and not within RIM of the open outside or of the
        grid's frame (beyond it the outside is open); collective."""
        nx, ny = self.layout.shape
        r0, r1 = self.layout.rows
        outside = np.ones((r1 - r0) * ny, dtype=bool)
        outside[self.layout.positions[members]] = False
        outside = outside.reshape(r1 - r0, ny)
        holes = enclosed(outside, self.comm, r0, nx)
        near_hole = _near(holes, self.comm, r0, nx, beyond=False)
        near_open = _near(outside & ~holes, self.comm, r0, nx, beyond=True)
        self.rim = (near_hole & ~near_open).reshape(-1)
        self.labelled = True

    def update(self, nodes: np.ndarray, edge: np.ndarray) -> None:
        """The charge on the free set given by this rank's node indices and its edge weights
        ``edge`` (on the same nodes); collective."""
        ny = self.layout.shape[1]
        positions = self.layout.slab_positions(nodes)
        # only the rims' nodes carry charge: near full contact at 2048² the blocks and scales of
        # every node of S took 59 ms an update and the block sums 27 ms a subtraction
        self.on_rim = np.flatnonzero(self.rim[positions])
        positions = positions[self.on_rim]
        rows, columns = np.divmod(positions, ny)
        rows += self.layout.rows[0]
        self.blocks = ((rows // self.block) * self.grid[1] + columns // self.block).astype(np.int32)
        self.charge = edge[self.on_rim] * self.factor
        totals = self.comm.allreduce(_block_sums(self.blocks, self.charge, self.count))
        inverse = np.divide(1.0, totals, out=np.zeros_like(totals), where=totals > 0)
        self.scale = self.charge * inverse[self.blocks]
        self.active = bool(np.any(totals > 0))

    def subtract(self, g: np.ndarray, z: np.ndarray) -> None:
        """z −= Σ_b r_b (r_bᵀ g) / (1ᵀ r_b) on the free set of the last :meth:`update`; collective."""
        if not self.active:
            return
        sums = self.comm.allreduce(_block_sums(self.blocks, self.charge * g[self.on_rim], self.count))
        z[self.on_rim] -= self.scale * sums[self.blocks]


def _block_sums(blocks: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """The sum of ``values`` on each of ``count`` blocks, float64 also where no node is on a rim
    (np.bincount of nothing is integer)."""
    return np.bincount(blocks, weights=values, minlength=count).astype(float, copy=False)


def _near(field: np.ndarray, comm, first_row: int, rows_total: int, beyond: bool) -> np.ndarray:
    """The nodes of this rank's (rows, ny) slab within RIM nodes (a square) of a True node of
    ``field`` over all ranks (rows ``first_row`` on of ``rows_total``); ``beyond``: the nodes past
    the grid's edges count as True; collective (the RIM rows beyond the slab's ends come from
    the ranks that hold them, :func:`~roughcontact.surfaces.rows.rows_window`)."""
    rows, ny = field.shape
    start, stop = (max(first_row - RIM, 0), min(first_row + rows + RIM, rows_total)) if rows \
        else (first_row, first_row)
    window = np.full((rows + 2 * RIM, ny + 2 * RIM), beyond)   # rows and columns past the grid keep it
    window[start - first_row + RIM:stop - first_row + RIM, RIM:RIM + ny] = \
        rows_window(field, (first_row, first_row + rows), (start, stop), comm)
    # the square's maximum as ORs of shifted views, along y and then x: scipy's maximum_filter
    # took 115 ms a call on a 4096² slab, 1.8 s of the large-grid scene's solve
    across = window[:, :ny].copy()
    for shift in range(1, 2 * RIM + 1):
        across |= window[:, shift:shift + ny]
    grown = across[:rows].copy()
    for shift in range(1, 2 * RIM + 1):
        grown |= across[shift:shift + rows]
    return grown
