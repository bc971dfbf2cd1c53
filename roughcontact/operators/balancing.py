"""A coarse space for the settled contact set: the balancing preconditioner on blocks of the set.

Once the contact set has settled, the constrained CG converges at the rate the
condition number κ of M H_SS allows (M the Fourier preconditioner with its edge
correction and hole charge, :mod:`.preconditioner`, :mod:`.holes`). On the
large-grid scene that κ grows with the grid at its top. A field of one sign on
an island pays the charge κ_i that the correction leaves, and κ_i falls only like
1/d inside the island, so the sum grows with the log of the island's size in
nodes. On the solved set at 4096² the Ritz range was 0.408–5.08 (κ 12.5), against
0.431–2.93 at 1024² (docs/solver-cost.md, "The top of the spectrum at 4096²").

The fields that pay too much are smooth over large parts of the set, which a
few vectors hold. Z holds the indicators of the set's nodes in each of
BALANCING_PARTS² square blocks of the grid, and

    P = Z E⁻¹ Zᵀ + (I − Z E⁻¹ Wᵀ) M (I − W E⁻¹ Zᵀ),    E = Zᵀ W,

the balancing form (Mandel's balancing Neumann–Neumann; J. Mandel, Commun.
Numer. Methods Eng. 9 (1993) 233–241; in the notation of Tang, Nabben, Vuik and
Erlangga, J. Sci. Comput. 39 (2009) 340–370). With W = H_SS Z, P H_SS is the
identity on the span of Z and M H_SS on its H-orthogonal complement. P is
symmetric positive definite for any W with Zᵀ W symmetric positive definite, so
an approximate W costs rate, never correctness. W here is C Z: the circulant of
the preconditioner, whose inverse M already applies, on its period. C equals H
for every pair of nodes closer than half the period, and the periodic product
costs about a quarter of a padded one. W is made once per solve from a fresh
start (the evaluations of a free rotation share it), on the free set of the
iteration where the hole charge is first taken. Nodes that enter the set
later have no row in Z or W, and nodes that left lose theirs. E is taken again
on the set of each iteration.

Whole solves of the large-grid scene, one rank, fine iterations (coarse in
brackets), with the coarse space on the levels of BALANCING_FROM nodes or more:

- 4096², seeds 1 / 2 / 3: 29 / 30 / 25 → 25 / 25 / 23 (14 / 13 / 12);
- 2048² (below BALANCING_FROM), seed 1: 21; with the space from 2048² up
  20, and the 4096² solves 25 / 25 / 24, their 2048² levels taking it too.

The time stays about the same: W's products cost about what the iterations
saved do. Alternated in one process at 4096², seed 1 took 31.58 s against
32.09 s (medians of 4), and seed 2 32.90 s against 31.25 s (medians of 3,
the machine's spread 29.3–37.1 s). Near full contact (Δ = 2.5, 1 E*) the
free set holds 86 % of the nodes, above BALANCING_SHARE, so no space is made.
W = H Z, made exactly by padded products, took 24 fine iterations at 4096²
(seed 1) and 5.7 s against C Z's 2.5 s. See docs/solver-cost.md, "A
balancing coarse space on blocks of the set".

The space is kept only where the free set that makes it is sparse (at most
BALANCING_SHARE = 1/8 of the grid's nodes). W holds k ≤ 16 float32 values per
node of that set. Once the set has changed, its rows are copied for the set of
the moment, as many again. Together they are at most 2 × 64 / 8 = 16 B per node
of the grid; on the large-grid scene at 4096² (1.8 % of the nodes) they are
at most 2.4 B per node.
"""
from __future__ import annotations

import logging

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

#: the blocks per side of the grid whose nodes of the set are the columns of Z (at most the
#: square of this many vectors)
BALANCING_PARTS = 4
#: the grids (nodes) whose levels take the coarse space. At 2048² it saved one fine iteration of
#: 21 on the large-grid scene, and the solve took 6.14 s against 5.97 (medians of 6, alternated);
#: at 1024² none
BALANCING_FROM = 4096 * 4096
#: the largest free set (a share of the grid's nodes) on which the coarse space is made: W and its
#: rows on a later set are k float32 values per node of the set each, at most 16 B per node of the
#: grid together (the large-grid scene's sets hold 2 % of it; near full contact 86 %)
BALANCING_SHARE = 0.125

_log = logging.getLogger(__name__)


class BalancingSpace:
    """The balancing coarse space of a free set on the layout of a
    :class:`~.flexibility.Flexibility` (module docstring): :meth:`make` once, then
    :meth:`apply` around the solver's preconditioner on each iteration's free set."""

    def __init__(self, preconditioner, layout, comm, parts: int = BALANCING_PARTS):
        self.preconditioner, self.layout, self.comm = preconditioner, layout, comm
        self.parts = int(parts)
        self.nodes: np.ndarray | None = None            # the free set W was made on (local, ascending)
        self.column = np.zeros(0, dtype=np.intp)        # the column of Z of each of those nodes
        self.W = np.zeros((0, 0), dtype=np.float32)     # C Z on those nodes
        self.count = 0                                  # columns of Z (over all ranks)
        self._cached: tuple | None = None               # the last free set's rows, and E's factor
        self._warned = False                            # whether a set without E's factor was reported

    @property
    def made(self) -> bool:
        """Whether :meth:`make` has been called."""
        return self.nodes is not None

    def make(self, nodes: np.ndarray, single: bool) -> None:
        """Z and W = C Z on the free set given by this rank's ascending node indices: one periodic
        product per block that holds nodes of the set on any rank (``single``: in single
        precision); collective."""
        nx, ny = self.layout.shape
        side = -(-max(nx, ny) // self.parts)
        positions = self.layout.slab_positions(nodes)
        rows, columns = np.divmod(positions, ny)
        block = ((self.layout.rows[0] + rows) // side) * self.parts + columns // side
        counts = self.comm.allreduce(np.bincount(block, minlength=self.parts ** 2))
        present = np.flatnonzero(counts)
        lookup = np.full(self.parts ** 2, -1, dtype=np.intp)
        lookup[present] = np.arange(present.size)
        column, count = lookup[block], int(present.size)
        W = np.empty((nodes.size, count), dtype=np.float32)
        with self.preconditioner.circulant() as circulant:
            for j in range(count):
                W[:, j] = circulant.apply_nodes((column == j).astype(float), nodes, single)
        self.column, self.count, self.W, self._cached = column, count, W, None
        self.nodes = nodes.copy()                       # last: made only once W is whole

    def apply(self, g: np.ndarray, nodes: np.ndarray, precondition) -> np.ndarray:
        """P g on the free set given by this rank's node indices ``nodes``, for the solver's
        preconditioner ``precondition`` (a callable: M x on the same set); M g alone where E is
        not positive definite on the set; collective."""
        column, rows, factor = self._rows(nodes)
        if factor is None:
            return precondition(g)
        k = self.count
        y = cho_solve(factor, self._block_sums(column, g[:, None])[:, 0])
        z = precondition(g - rows @ y.astype(np.float32))
        t = cho_solve(factor, self.comm.allreduce((rows.T @ z.astype(np.float32)).astype(float)))
        correction = np.zeros(k + 1)                    # index k: the nodes without a column
        correction[:k] = y - t
        z += correction[np.where(column < 0, k, column)]
        return z

    def _block_sums(self, column: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Zᵀ values over all ranks for the columns of ``values`` (one row per node of the set),
        (count, columns) in float64: one reduction."""
        valid = column >= 0
        width = values.shape[1]
        index = (column[valid][:, None] * width + np.arange(width)).ravel()
        local = np.bincount(index, weights=values[valid].ravel(), minlength=self.count * width)
        return self.comm.allreduce(local.reshape(self.count, width))

    def _rows(self, nodes: np.ndarray):
        """(the column of Z of each node of the free set, −1 where it has none; W's rows there, a
        zero row where it has none; the Cholesky factor of E = Zᵀ W on the set), kept while the
        set stays the same."""
        kept = self._cached is not None and np.array_equal(self._cached[0], nodes)   # shapes first
        if self.comm.allreduce(int(not kept)) == 0:     # the same on every rank: E is a reduction
            return self._cached[1:]
        self._cached = None                             # its rows let go before the new ones are made
        if np.array_equal(self.nodes, nodes):
            column, rows = self.column, self.W
        else:
            valid = np.isin(nodes, self.nodes, assume_unique=True)
            place = np.searchsorted(self.nodes, nodes[valid])
            column = np.full(nodes.size, -1, dtype=np.intp)
            column[valid] = self.column[place]
            rows = np.zeros((nodes.size, self.count), dtype=np.float32)
            rows[valid] = self.W[place]
        sums = self._block_sums(column, rows)
        matrix = 0.5 * (sums + sums.T)
        # a block whose nodes all left the set: its column of Z is zero, and E's row and column too
        empty = self.comm.allreduce(np.bincount(column[column >= 0], minlength=self.count)) == 0
        matrix[empty, :] = matrix[:, empty] = 0.0
        matrix[empty, empty] = 1.0
        try:
            factor = cho_factor(matrix)
        except (LinAlgError, ValueError):              # not positive definite, or not finite
            factor = None
        # E is the same on every rank, but the factor's success is agreed on: a rank that went
        # without the coarse space alone would leave the others in its reductions
        if self.comm.allreduce(int(factor is None)):
            if not self._warned:                        # once per space: it may recur as the set moves
                _log.warning("the balancing coarse space's E = Zᵀ W is not positive definite on this "
                             "free set: the preconditioner goes on without it while the set stays")
            factor, self._warned = None, True
        self._cached = (nodes.copy(), column, rows, factor)
        return column, rows, factor
