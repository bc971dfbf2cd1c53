"""The Fourier preconditioner on a smooth extension of the set's field, for sets that are a dust.

The solver's preconditioner of H_SS is M = R_S A R_Sᵀ (A = C⁻¹, C the kernel's
circulant on its period, :mod:`.preconditioner`), less the edge correction and
the hole charge, which approximate the Schur term of the exact inverse of C on
the set, C_SS⁻¹ = A_SS − A_SO A_OO⁻¹ A_OS (O the nodes outside S). That Schur
complement is the least of Eᵀ A E over the extensions E = [I; T] of a field on
S to the nodes outside it (the least at T = −A_OO⁻¹ A_OS, the field whose
traction vanishes off S). So for ANY map T from S to O,

    M_T = Eᵀ A E,  M_T g = R_S A (E g) + Tᵀ R_O A (E g),

is symmetric, positive definite, at least C_SS⁻¹ (M_T C_SS ≥ 1: the smallest
eigenvalue is kept where the edge correction lowers it) and M at T = 0.

M prices a field on S as if the ground between its nodes were held flat. On a
set of many small islands (a smooth surface at low slopes, the contact of an
ensemble task's sweep: 2 500–8 500 islands of 5–13 nodes on average at
513², 4–40 % in contact) a field of one sign over the dust then pays far too
much: the top Ritz value of the solver's M H_SS was 10–25, where C_SS⁻¹
itself gives 1.2–1.9 (benchmarks/bench_extension.py). T here is a
normalised box average of the set's values,

    T g = B(g) / max(B(1_S), τ)  on O,

B the box filter of EXTENSION_WIDTH nodes a side over the grid (zero beyond
it), τ = EXTENSION_FLOOR: next to the set the extension is the local mean of
its values, and it fades where the box holds little of the set. Fixed-set
PCG on the task's solved sets (4 / 14 / 40 / 82 % in contact, 513²): 29 /
35 / 37 / 24 iterations with the solver's preconditioner, 15 / 18 / 18 / 14
with M_T, 7 / 10 / 12 / 11 with C_SS⁻¹. On sets of large islands it does
not pay: on the large-grid scene (2 % in contact, 26 islands) the solver's
took 12 iterations and M_T 13, near full contact (87 %, 9 islands) 14 and
16. The boundary's share of the set tells the two apart (the nodes of S with a 4-neighbour outside it:
0.40–0.91 on the task's sets, 0.27 and 0.08 on the scenes), so the solver
takes M_T where that share is EXTENSION_BOUNDARY or more (:meth:`chosen`).
M_T and the edge correction do not combine: M_T less any share of the edge
weights was indefinite on the task's sets.

One application costs the same periodic product as M (of a field on every
node of the rank instead of S's) and two box filters (:meth:`_box`; their
output in the product's precision), with a halo of EXTENSION_WIDTH // 2
rows from the neighbouring ranks each: 4.4 against M's 4.1 ms at 513² (the
task's set of 40 %, single precision, medians of 9), 85.7 against 54.0 ms
at 2049² (72 %; docs/solver-cost.md, "M_T's passes, and the corrections it
replaces"). The weights are made once per set, and only for a set that
takes the extension; the solver makes neither the edge weights nor the
hole charge for such a set.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..surfaces.rows import padded_rows, reached_rows, rows_window
from . import passes
from .set_blocks import held_for_set

#: the levels (nodes) from which the solver takes the extension (``CGSettings.extension_from``):
#: measured on the ensemble task's sweeps at 17²–2049², 12-load tasks at 40² and 48², the default
#: study's 24 tasks at 65², and the large-grid scenes at 64²–4096² (docs/solver-cost.md, "The
#: extension from 64²" and "… from 16²"); the nested start's levels stop at 64² (COARSEST)
EXTENSION_FROM = 16 * 16
#: the box filter's side (nodes, odd). Fixed-set PCG on the ensemble task's sets at 4 / 14 / 40 /
#: 82 % in contact (513²): 5: 16 / 20 / 20 / 14; 7: 15 / 18 / 18 / 14; 9: 15 / 18 / 18 / 14 (a
#: Gaussian of σ = 2 nodes: 15 / 18 / 18 / 14, at 4.6 against the box's 1.2 ms at 513²); 3 (a
#: scratch copy with float32 filters): 20 / 25 / 25 / 16
EXTENSION_WIDTH = 7
#: τ, the floor of the normalisation B(1_S): with a box of 5 nodes, 0.1 took 20 / 23 / 21 / 14 and
#: 0.3 17 / 20 / 20 / 14 in a scratch copy with float32 filters (the package's: 16 / 20 / 20 / 14)
EXTENSION_FLOOR = 0.3
#: the boundary share of the set (its nodes with a 4-neighbour outside it) from which the
#: extension replaces the edge correction and the hole charge: 0.40–0.91 where it paid, 0.08 and
#: 0.27 where it did not (module docstring)
EXTENSION_BOUNDARY = 1.0 / 3.0
#: the bytes of output rows the box filter makes at a time, each block's passes in cache
#: (:meth:`SmoothExtension._box`): 127 rows of 2049 in float32
BLOCK_BYTES = 1 << 20


class SmoothExtension:
    """M_T on the layout of a :class:`~.flexibility.Flexibility` (module docstring): :meth:`chosen`
    tells whether a free set takes it, :meth:`apply` applies it there. The set's weights are
    made on the first call for a set and kept while it stays."""

    def __init__(self, preconditioner, layout, comm, width: int = EXTENSION_WIDTH,
                 floor: float = EXTENSION_FLOOR):
        if width < 1 or width % 2 == 0:
            raise ValueError(f"the box filter's width must be odd and positive, got {width}")
        if not floor > 0.0:
            raise ValueError(f"the floor of the normalisation must be positive, got {floor}")
        self.preconditioner, self.layout, self.comm = preconditioner, layout, comm
        self.width, self.floor = int(width), float(floor)
        self.convolution = preconditioner.convolution   # A = C⁻¹ on its period, a slab at a time
        self.workers = self.convolution.workers
        self._nodes: np.ndarray | None = None           # the set the two below belong to
        self._share: float | None = None                # its boundary share (None: not yet counted)
        # the weight 1/max(B(1_S), τ) off S, and the nodes' positions in the slab and in the
        # product's rows (None: not yet made; only a set that takes the extension needs them)
        self._made: tuple | None = None
        self._buffers: tuple | None = None              # :meth:`_scratch`'s three slabs
        self._zeroed: np.ndarray | None = None          # the positions g's field is zero off

    # ------------------------------------------------------------------ the set
    def chosen(self, nodes: np.ndarray) -> bool:
        """Whether the free set given by this rank's ascending node indices takes the extension:
        its boundary share is EXTENSION_BOUNDARY or more (the same answer on every rank;
        collective)."""
        return self.boundary_share(nodes) >= EXTENSION_BOUNDARY

    def boundary_share(self, nodes: np.ndarray) -> float:
        """The share of the set's nodes (this rank's ascending node indices ``nodes``) with a
        4-neighbour outside it, beyond the grid counting as outside (the punch ends there), over
        all ranks; kept while the set stays the same (collective)."""
        self._keep(nodes)
        if self._share is None:
            inside = np.zeros(self.layout.local_mask.shape, dtype=bool)
            inside.reshape(-1)[self.layout.slab_positions(nodes)] = True
            self._share = self._counted_boundary(inside, nodes.size)
        return self._share

    def _keep(self, nodes: np.ndarray) -> None:
        """Forget what was kept for another set than ``nodes`` (on every rank where any rank's set
        changed: the kept values are reductions; collective)."""
        kept = self._nodes is not None and np.array_equal(self._nodes, nodes)
        if self.comm.allreduce(int(not kept)):
            # g's field too: its zeros were for the set forgotten (the new set's positions may be
            # the same array object, refilled)
            # the last set's copy goes first: its ladder block's place, or its mapping's pages
            # (held_for_set), are free before the next one is made
            self._nodes, self._share, self._made, self._zeroed = None, None, None, None
            self._nodes = held_for_set(nodes.size, nodes.dtype)
            self._nodes[:] = nodes

    def _weights(self, nodes: np.ndarray) -> tuple:
        """(the weight 1 / max(B(1_S), τ) on the footprint off S, 0 on S and off the footprint, as
        this rank's slab in float32; the set's flat slab positions, its flat positions in the
        product's uncropped rows of Ly columns, and where each slab row's nodes start among them),
        kept while the set stays the same (collective)."""
        self._keep(nodes)
        if self._made is None:
            layout = self.layout
            positions = layout.slab_positions(nodes)
            ny, ly = layout.shape[1], self.convolution.lengths[1]
            period = positions
            if ly > ny:                             # row × Ly + column, held while the set is
                period = np.floor_divide(positions, ny, out=held_for_set(positions.size, positions.dtype))
                period *= ly - ny
                period += positions
            starts = np.searchsorted(positions, np.arange(layout.local_mask.shape[0] + 1) * ny)
            member = np.zeros(layout.local_mask.shape, dtype=np.float32)
            member.reshape(-1)[positions] = 1.0
            weight = self._box(member)
            np.maximum(weight, np.float32(self.floor), out=weight)
            np.reciprocal(weight, out=weight)
            weight[member > 0.0] = 0.0
            weight[~layout.local_mask] = 0.0
            self._made = (weight, positions, period, starts)
        return self._made

    def _counted_boundary(self, inside: np.ndarray, count: int) -> float:
        """The share of the set's nodes (``inside``: this rank's slab mask; ``count`` of them on this
        rank) with a 4-neighbour outside it, over all ranks (collective)."""
        padded = padded_rows(inside, self.layout.rows, self.layout.shape[0], 1, False, self.comm)
        interior = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
        boundary = np.count_nonzero(inside & ~interior)
        total, edge = self.comm.allreduce(np.array([count, boundary], dtype=np.int64))
        return float(edge) / float(total) if total else 0.0

    def _box(self, slab: np.ndarray, out: np.ndarray | None = None, then=None) -> np.ndarray:
        """B(slab): the box filter of ``width`` nodes a side over the grid, zero beyond it, on this
        rank's rows, in ``slab``'s precision, into ``out`` (a new array if None; not ``slab``).
        The rows within width // 2 of the rank's own come from its neighbours (collective).
        ``then(start, stop)`` is called on each block of output rows as soon as it is made,
        while it is still in cache (the passes :meth:`apply` makes on B's values).

        On the FFT's threads, by blocks of about BLOCK_BYTES of output rows: along y by scipy's
        running sums (which release the GIL) into a scratch block of the block's rows and
        width − 1 more, then across as the sum of the ``width`` scratch rows about each row,
        contiguous adds in cache (scipy's filter along x, which reads the columns strided, took
        29.6 against 9.3 ms for whole-slab adds at 2049²). In blocks, against the same passes
        over whole slabs (one process, alternated, medians of 15; the same bits): 9.8–10.8
        against 15.6–17.3 ms at 2049², 1.1 against 1.2 ms at 513² (float32, two threads)."""
        half = self.width // 2
        r0, r1 = self.layout.rows
        lo, hi = reached_rows((r0, r1), self.layout.shape[0], half)
        # rows_window is collective: every rank of a communicator of more than one takes part
        window = slab if self.comm.Get_size() == 1 else rows_window(slab, (r0, r1), (lo, hi), self.comm)
        count, ny = window.shape
        first = r0 - lo                             # the window's row of the rank's first row
        if out is None:
            out = np.empty((r1 - r0, ny), dtype=window.dtype)
        width, scale = self.width, window.dtype.type(1.0 / self.width)
        block_rows = max(1, BLOCK_BYTES // max(1, ny * window.itemsize))

        def rows(a, b):
            along = np.empty((min(block_rows, b - a) + 2 * half, ny), dtype=window.dtype)
            for start in range(a, b, block_rows):
                stop = min(start + block_rows, b)
                # the window rows the block's rows sum: those within half of them
                w0, w1 = max(start + first - half, 0), min(stop + first + half, count)
                summed = along[:w1 - w0]
                uniform_filter1d(window[w0:w1], width, axis=1, mode="constant", output=summed)
                block = out[start:stop]
                block.fill(0.0)
                for shift in range(-half, half + 1):
                    i0, i1 = max(start, w0 - first - shift), min(stop, w1 - first - shift)
                    if i1 > i0:
                        block[i0 - start:i1 - start] += summed[i0 + first + shift - w0:i1 + first + shift - w0]
                block *= scale
                if then is not None:
                    then(start, stop)

        passes.by_rows(self.workers, r1 - r0, rows)
        return out

    # ---------------------------------------------------------------- the product
    def apply(self, values: np.ndarray, nodes: np.ndarray, single: bool = False) -> np.ndarray:
        """M_T g on the free set given by this rank's ascending node indices ``nodes``, ``values``
        = g there (float64 out; the filters and the periodic product in single precision with
        ``single``; T and Tᵀ take the same float32 weights, so M_T is symmetric in either);
        collective.

        E g is written by the first box's last passes straight into the product's padded rows
        (:meth:`~.convolution.SlabConvolution.apply_written`), A E g is read at S from the
        uncropped product by flat positions, Tᵀ's values at S are gathered block by block as
        the second box makes them, and three slabs of scratch are kept for the solve: at 2049²
        (a set of 72 %, single precision) 74.4 against 94.9 ms an application where each slab
        was new, E g copied into the buffer and A E g read at S by rows and columns of its
        cropped view (alternated in one process, medians of 15; the same bits)."""
        weight, positions, period, starts = self._weights(nodes)
        dtype = np.float32 if single else np.float64
        workers = self.workers
        field, back, filtered = self._scratch(dtype)
        if self._zeroed is not positions:           # g's field keeps its zeros while S stays
            passes.fill(field, 0.0, workers)
            self._zeroed = positions
        passes.scatter(field.reshape(-1), positions, values, workers)

        def extend(block):
            def then(a, b):                         # T g off S (the weight is 0 on S), g on S: E g
                block[a:b] *= weight[a:b]
                block[a:b] += field[a:b]
            self._box(field, out=block, then=then)

        whole = self.convolution.apply_written(extend, single)      # A E g, rows of Ly columns
        out = passes.gather(whole.reshape(-1), period, workers).astype(float, copy=False)
        passes.combine(np.multiply, whole[:, :self.layout.shape[1]], weight, back, workers)
        flat = filtered.reshape(-1)

        def gathered(a, b):                         # + Tᵀ R_O A E g on S's nodes of rows a … b
            i0, i1 = starts[a], starts[b]
            out[i0:i1] += flat[positions[i0:i1]]

        self._box(back, out=filtered, then=gathered)
        return out

    def _scratch(self, dtype) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Three slabs of the rank's rows in ``dtype``, kept while this object lives (a solve): g's
        field (zero off the set it was last filled for), w ∘ A E g, and its box filter."""
        if self._buffers is None or self._buffers[0].dtype != dtype:
            self._buffers = tuple(np.empty(self.layout.local_mask.shape, dtype=dtype) for _ in range(3))
            self._zeroed = None
        return self._buffers
