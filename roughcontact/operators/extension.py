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
node of the rank instead of S's) and two box filters (along y scipy.ndimage's
running sums, along x sums of whole rows; their output in the product's
precision), with a halo of EXTENSION_WIDTH // 2 rows from the neighbouring
ranks each: 7.0 against M's 3.7 ms at 513² (a set of 40 %, single
precision, medians of 9), 114 against 41 ms at 2049² (72 %). The weights
are made once per set, and only for a set that takes the extension.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..surfaces.rows import padded_rows, rows_window
from . import passes

#: the levels (nodes) from which the solver takes the extension (``CGSettings.extension_from``):
#: measured on 513², 1025² and 2049² sweeps and on the large-grid scenes at 512²–4096²
EXTENSION_FROM = 512 * 512
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
        # the weight 1/max(B(1_S), τ) off S, and the nodes' slab positions, rows and columns (None:
        # not yet made; only a set that takes the extension needs them)
        self._made: tuple | None = None

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
            self._nodes, self._share, self._made = nodes.copy(), None, None

    def _weights(self, nodes: np.ndarray) -> tuple:
        """(the weight 1 / max(B(1_S), τ) on the footprint off S, 0 on S and off the footprint, as
        this rank's slab in float32; the set's flat slab positions, and its rows in the slab and
        columns), kept while the set stays the same (collective)."""
        self._keep(nodes)
        if self._made is None:
            layout = self.layout
            positions = layout.slab_positions(nodes)
            rows, columns = np.divmod(positions, layout.shape[1])
            member = np.zeros(layout.local_mask.shape, dtype=np.float32)
            member.reshape(-1)[positions] = 1.0
            weight = self._box(member)
            np.maximum(weight, np.float32(self.floor), out=weight)
            np.reciprocal(weight, out=weight)
            weight[member > 0.0] = 0.0
            weight[~layout.local_mask] = 0.0
            self._made = (weight, positions, rows, columns)
        return self._made

    def _counted_boundary(self, inside: np.ndarray, count: int) -> float:
        """The share of the set's nodes (``inside``: this rank's slab mask; ``count`` of them on this
        rank) with a 4-neighbour outside it, over all ranks (collective)."""
        padded = padded_rows(inside, self.layout.rows, self.layout.shape[0], 1, False, self.comm)
        interior = (padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:])
        boundary = np.count_nonzero(inside & ~interior)
        total, edge = self.comm.allreduce(np.array([count, boundary], dtype=np.int64))
        return float(edge) / float(total) if total else 0.0

    def _box(self, slab: np.ndarray) -> np.ndarray:
        """B(slab): the box filter of ``width`` nodes a side over the grid, zero beyond it, on this
        rank's rows, in ``slab``'s precision, a new array (the rows within width // 2 of its own
        come from its neighbours; collective). On the FFT's threads by blocks of rows: along y by
        scipy's running sums (which release the GIL), along x as the sum of the ``width`` rows
        about each row, contiguous adds that took 9.3 ms at 2049² (float32, two threads) where
        scipy's filter along x, which reads the columns strided, took 29.6 ms."""
        half = self.width // 2
        r0, r1 = self.layout.rows
        nx = self.layout.shape[0]
        lo, hi = max(r0 - half, 0), min(r1 + half, nx)
        # rows_window is collective: every rank of a communicator of more than one takes part
        window = slab if self.comm.Get_size() == 1 else rows_window(slab, (r0, r1), (lo, hi), self.comm)
        along = np.empty_like(window)
        out = np.empty((r1 - r0, window.shape[1]), dtype=window.dtype)
        width, scale = self.width, window.dtype.type(1.0 / self.width)
        count = window.shape[0]

        def rows(a, b):
            uniform_filter1d(window[a:b], width, axis=1, mode="constant", output=along[a:b])

        def across(a, b):
            # out rows a:b are window rows a + first … b + first; each sums window rows within half
            first = r0 - lo
            block = out[a:b]
            block.fill(0.0)
            for shift in range(-half, half + 1):
                start, stop = a + first + shift, b + first + shift
                skip, keep = max(0, -start), (b - a) - max(0, stop - count)
                if keep > skip:
                    block[skip:keep] += along[start + skip:start + keep]
            block *= scale

        passes.by_rows(self.workers, count, rows)
        passes.by_rows(self.workers, r1 - r0, across)
        return out

    # ---------------------------------------------------------------- the product
    def apply(self, values: np.ndarray, nodes: np.ndarray, single: bool = False) -> np.ndarray:
        """M_T g on the free set given by this rank's node indices ``nodes``, ``values`` = g there
        (float64 out; the filters and the periodic product in single precision with ``single``;
        T and Tᵀ take the same float32 weights, so M_T is symmetric in either); collective."""
        weight, positions, rows, columns = self._weights(nodes)
        dtype = np.float32 if single else np.float64
        workers = self.workers
        field = np.zeros(self.layout.local_mask.shape, dtype=dtype)
        passes.scatter(field.reshape(-1), positions, values, workers)
        extended = self._box(field)
        passes.combine(np.multiply, extended, weight, extended, workers)   # T g off S, 0 on S
        passes.scatter(extended.reshape(-1), positions, values, workers)   # E g
        # A E g on this rank's rows: a strided view of the period, read at S by rows and columns
        z = self.convolution.apply(extended, single)
        back = passes.combine(np.multiply, z, weight, np.empty(z.shape, dtype=dtype), workers)
        out = z[rows, columns].astype(float)
        out += passes.gather(self._box(back).reshape(-1), positions, workers)
        return out
