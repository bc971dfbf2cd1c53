"""Convolution with an even kernel on a grid whose rows are split over MPI ranks (slab FFT).

The flexibility operator of Eq. 10 is a convolution: H_ij depends only on
the offset (|Δi|, |Δj|) between nodes. Its product with a field x on an
(nx, ny) grid is computed with FFTs, either

- **non-periodic** (the half-space, no wrap-around): the field is padded with
  zeros to an (Lx, Ly) grid with Lx ≥ 2 nx − 1, Ly ≥ 2 ny − 1, so the
  circular convolution with the kernel extended evenly to negative offsets
  equals the linear one on the original nodes, exactly (to round-off); or
- **periodic**: the (nx, ny) grid itself is one period (Lx = nx, Ly = ny), or
  sits in one corner of a longer period (n ≤ L ≤ 2n − 1) with zeros around
  it (the Fourier preconditioner of a bounded grid,
  :mod:`~roughcontact.operators.preconditioner`).

Distribution (a slab decomposition): rank r owns the grid rows
[row_start, row_stop). A product is

1. a real FFT along y of the owned rows (zero-padded to Ly: only the nx
   non-zero rows are transformed, never the padding);
2. a transpose (``Alltoallv``) to blocks of the Ly/2 + 1 frequency columns,
   each rank holding all nx rows of its columns;
3. an FFT along x zero-padded to Lx, the product with the kernel's symbol
   (real: the kernel is even), the inverse FFT, keeping the first nx rows;
4. the transpose back and the inverse real FFT along y, keeping ny columns.

Because the padding is never transformed along y and only nx rows come
back along x, a product costs about 0.7 of a plain padded 2-D FFT pair.
FFTs are scipy's (pocketfft), measured faster here than FFTW's Python
wrapper for these sizes; ``workers`` threads split each batch of 1-D
transforms when a rank has more than one core, and the passes between the
transforms by blocks of rows (:mod:`.passes`).

A product may be taken in single precision (``single=True``: float32
fields, complex64 spectra, the symbol rounded to float32): about half the
time of the double one from 513² to 2049², with a relative error of about
1e-7 of the result's scale. The solvers use it only where that error is
harmless (search directions and the preconditioner of the constrained CG,
:mod:`roughcontact.normal.constrained_cg`).
"""
from __future__ import annotations

import os
from contextlib import contextmanager

import numpy as np
import scipy.fft as sfft

from ..surfaces.rows import split
from . import passes
from .heap import MAPPED_FROM, retain_large_blocks


def padded_lengths(shape: tuple[int, int], periodic: bool,
                   period: tuple[int, int] | None = None) -> tuple[int, int]:
    """(Lx, Ly): the transform lengths, fast FFT sizes ≥ 2n − 1 unless periodic; ``period`` where
    given (a periodic convolution whose period is longer than the grid)."""
    nx, ny = shape
    if period is not None:
        return int(period[0]), int(period[1])
    if periodic:
        return nx, ny
    return sfft.next_fast_len(2 * nx - 1), sfft.next_fast_len(2 * ny - 1, real=True)


#: variables in which MPI launchers give the number of ranks on this node (MPICH's Hydra,
#: Open MPI, Slurm): read without a collective, so an operator on a sub-communicator (a farm
#: group) still counts every rank of the job that shares the node's cores
LOCAL_RANKS_VARIABLES = ("MPI_LOCALNRANKS", "OMPI_COMM_WORLD_LOCAL_SIZE", "SLURM_NTASKS_PER_NODE")


#: Padded points per rank from which FFTs use threads. A product on one rank
#: with one thread against two: 0.06 against 0.41 ms at 33², 0.7 against 1.0 ms
#: at 129², even at 257², 13 against 10 ms at 513², 75 against 59 ms at 1025².
THREADED_POINTS = 512 * 512
#: what one more call of the transform along y costs, in points transformed: a sparse field's
#: transform takes only the runs of rows that hold its values where the points of the rows it
#: skips exceed this many per run (:meth:`SlabConvolution._transform`). Rows of 8192 points
#: (4096² padded, single precision), medians of 6 products taking every run alone against all
#: rows: one occupied row in two 343 against 300 ms, one in four 308 against 296 ms, one run of
#: half the rows 276 against 290 ms
RUN_POINTS = 40000
#: a field given at more than one node in this many of the slab is written dense
#: (:meth:`SlabConvolution.apply_at`): scattered into a zeroed flat slab and copied into the
#: padded rows, instead of scattered there at padded indices, whose integer division and
#: modulo cost more than the scatter itself
DENSE_WRITE = 8
#: how far from even in kx a symbol may be, relative to its largest value: a transform's round-off
#: (the symbols of the half-space and the periodic kernels are even to about 1e-16)
EVEN_TOLERANCE = 1e-9


def dense(nodes: int, size: int) -> bool:
    """Whether a field at ``nodes`` of a rank's ``size`` values counts as dense: more than one in
    :data:`DENSE_WRITE`. Written dense here (:meth:`SlabConvolution.apply_at`), and where a caller
    holds the whole field it hands that in instead of values at positions (the constrained CG's
    search direction, :class:`~.preconditioner.EdgeWeights`' set)."""
    return DENSE_WRITE * nodes > size


def default_workers(comm) -> int:
    """FFT threads per rank: the cores this process may use, shared by the ranks of its node.

    The ranks of the node come from the launcher's environment when it says
    (:data:`LOCAL_RANKS_VARIABLES`), otherwise from ``comm`` split by shared memory.
    """
    ranks_here = None
    for name in LOCAL_RANKS_VARIABLES:
        value = os.environ.get(name, "")
        if value.isdigit() and int(value) > 0:
            ranks_here = int(value)
            break
    if ranks_here is None:
        from mpi4py import MPI

        node = comm.Split_type(MPI.COMM_TYPE_SHARED)
        ranks_here = node.Get_size()
        node.Free()
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:      # pragma: no cover - not Linux
        cores = os.cpu_count() or 1
    return max(1, cores // ranks_here)


class SlabConvolution:
    """y = k ⊛ x for fields on an (nx, ny) grid with rows split over ``comm``.

    Parameters
    ----------
    shape
        (nx, ny) of the grid.
    comm
        mpi4py communicator; rank r owns rows :attr:`rows` = (row_start, row_stop)
        of :func:`split` (nx, size).
    periodic
        The grid is one period (True) or the domain of a half-space (False).
    period
        (Lx, Ly) with n ≤ L ≤ 2n − 1: a periodic convolution whose period is
        longer than the grid, which sits in its first rows and columns with
        zeros around it (implies ``periodic``).
    workers
        FFT threads per rank. By default one below :data:`THREADED_POINTS`
        padded points per rank (threads cost more than they save on small
        transforms), else :func:`default_workers`.

    The symbol is set with :meth:`set_kernel` (an even kernel table),
    :meth:`set_folded_kernel` (a table by |offset| folded onto a period) or
    :meth:`set_symbol` (its Fourier transform, computed elsewhere).
    """

    def __init__(self, shape: tuple[int, int], comm, periodic: bool = False, workers: int | None = None,
                 period: tuple[int, int] | None = None):
        self.shape = (int(shape[0]), int(shape[1]))
        self.comm = comm
        self.periodic = bool(periodic) or period is not None
        self.size, self.rank = comm.Get_size(), comm.Get_rank()
        self.lengths = padded_lengths(self.shape, self.periodic, period)
        if period is not None and not all(n <= length <= max(2 * n - 1, 1)
                                          for n, length in zip(self.shape, self.lengths)):
            raise ValueError(f"period {self.lengths} of the grid {self.shape}: each length must lie "
                             "between n and 2n − 1")
        if workers is None:
            points = self.lengths[0] * self.lengths[1] // self.size
            workers = default_workers(comm) if points >= THREADED_POINTS else 1
        self.workers = int(workers)
        self.columns = self.lengths[1] // 2 + 1                    # rfft output along y
        self.row_blocks = split(self.shape[0], self.size)
        self.column_blocks = split(self.columns, self.size)
        self.rows = self.row_blocks[self.rank]
        self.my_columns = self.column_blocks[self.rank]
        # the symbol (real, even in kx: the kernel is even) by its first Lx // 2 + 1 rows of this
        # rank's columns, the others being their mirror (:meth:`_filtered`); in single precision
        # each value twice, beside the real and imaginary parts it scales, made on first use
        self._half: np.ndarray | None = None
        self._single_half: np.ndarray | None = None
        # the padded rows and columns buffers of forward(), by precision: views of one storage of
        # the widest precision used so far, so that the single ones cost no memory of their own
        self._storage: tuple[np.ndarray, np.ndarray] | None = None
        self._buffers: dict[bool, tuple] = {}
        self._holder: bool | None = None                           # the precision that wrote last
        self._stamp = 0                         # transforms made so far (a held product's check)
        # where apply_at() last wrote into the rows buffer of each precision (None: anywhere, after
        # a whole field)
        self._written: dict[bool, np.ndarray | None] = {}
        if (self.rows[1] - self.rows[0]) * self.columns * np.dtype(np.complex128).itemsize > MAPPED_FROM:
            # this rank's transforms make blocks glibc would map afresh (and the kernel zero) at
            # every product: reused from the heap instead (:mod:`.heap`)
            retain_large_blocks()

    # ---------------------------------------------------------------- symbol
    def set_kernel(self, kernel: np.ndarray) -> None:
        """The symbol of the even kernel k(Δi, Δj) = kernel[|Δi|, |Δj|]: the whole (nx, ny) table,
        or only this rank's rows of it, (row_stop − row_start, ny) — all a rank transforms.

        Non-periodic: the table extended to negative offsets on the padded
        grid, zero at offsets beyond ±(n − 1), transformed (by cosine
        transforms of the table where both lengths are even,
        :meth:`_set_even_kernel`). Periodic: the
        table must already be the periodic kernel on one period, indexed by
        offset modulo n (use :meth:`set_symbol` for symbols computed in
        Fourier space, :meth:`set_folded_kernel` for a period longer than
        the grid).
        """
        nx, ny = self.shape
        lx, ly = self.lengths
        if self.periodic and self.lengths != self.shape:
            raise ValueError(f"a period {self.lengths} longer than the grid {self.shape} takes "
                             "set_folded_kernel")
        kernel = self._table_rows(kernel)
        if not self.periodic and lx % 2 == 0 and ly % 2 == 0:
            self._set_even_kernel(kernel)
            return
        rows = np.zeros((kernel.shape[0], ly))
        rows[:, :ny] = kernel
        if not self.periodic:
            rows[:, ly - ny + 1:] = kernel[:, :0:-1]                # negative y offsets
        columns = self._to_columns(sfft.rfft(rows, axis=1, workers=self.workers))   # (nx, my columns)
        full = np.zeros((lx, columns.shape[1]), dtype=complex)
        full[:nx] = columns
        if not self.periodic:
            full[lx - nx + 1:] = columns[:0:-1]                     # negative x offsets
        self._set_transformed(full)

    def _set_even_kernel(self, kernel: np.ndarray) -> None:
        """The symbol of this rank's rows of the even table K[|Δi|, |Δj|], both lengths even,
        non-periodic or folded onto its period: the kept rows kx = 0 … Lx / 2, by type-I cosine
        transforms along y and then x.

        With L = 2M the symbol of the kernel extended evenly onto the period is
        λ(k) = K(0) + 2 Σ_{0<j<M} K(j) cos(2π j k / L) + (−1)^k K(M), the type-I cosine transform
        of K(0 … M): of length M + 1 = L // 2 + 1, along y the rfft's column count and along x the
        rows kept. Non-periodic, the table (offsets up to n − 1 < M) is padded with zeros to M;
        folded (L ≤ 2n − 1, so M ≤ n − 1), it is read up to M. A quarter of the complex transform
        of the extended table, real throughout, and even by construction (at 1024² 18 against
        104 ms, docs/solver-cost.md, "The set-up: the kernel's symbol and the nodes' indices")."""
        nx, ny = self.shape
        width, height = min(ny, self.columns), min(nx, self._half_rows)
        rows = np.zeros((kernel.shape[0], self.columns))
        rows[:, :width] = kernel[:, :width]
        rows = sfft.dct(rows, type=1, axis=1, workers=self.workers, overwrite_x=True)
        half = np.zeros((self._half_rows, self.my_columns[1] - self.my_columns[0]))
        half[:height] = self._to_columns(rows)[:height]
        self._half = sfft.dct(half, type=1, axis=0, workers=self.workers, overwrite_x=True)
        self._single_half = None

    def set_folded_kernel(self, kernel: np.ndarray) -> None:
        """Periodic: the symbol of the even kernel given by |offset| (kernel[|Δi|, |Δj|], the whole
        table or this rank's rows, as :meth:`set_kernel`) folded onto the period: offset d takes
        the table's value at min(d, L − d), which is at most n − 1 for L ≤ 2n − 1 (the nearest
        image, on the grid's own period or a longer one)."""
        if not self.periodic:
            raise ValueError("a folded kernel needs a periodic convolution")
        lx, ly = self.lengths
        kernel = self._table_rows(kernel)
        if lx % 2 == 0 and ly % 2 == 0:
            self._set_even_kernel(kernel)
            return
        columns = self._to_columns(sfft.rfft(kernel[:, _folded(ly)], axis=1, workers=self.workers))
        self._set_transformed(columns[_folded(lx)])

    def _table_rows(self, kernel: np.ndarray) -> np.ndarray:
        """This rank's rows of a kernel table given whole or by this rank's rows."""
        kernel = np.asarray(kernel, dtype=float)
        r0, r1 = self.rows
        if kernel.shape == self.shape:
            return kernel[r0:r1]
        if kernel.shape != (r1 - r0, self.shape[1]):
            raise ValueError(f"kernel table has shape {kernel.shape}: neither the grid {self.shape} "
                             f"nor this rank's rows {(r1 - r0, self.shape[1])}")
        return kernel

    def _set_transformed(self, columns: np.ndarray) -> None:
        """The symbol from the kernel transformed along y, all Lx rows of this rank's columns."""
        self.set_symbol(sfft.fft(columns, axis=0, workers=self.workers).real)

    def set_symbol(self, symbol_columns: np.ndarray) -> None:
        """Set the symbol directly: this rank's columns, shape (Lx, my columns), real and even in
        kx (row Lx − k equal to row k to round-off, as the symbol of any even kernel is); only its
        first Lx // 2 + 1 rows are kept."""
        c0, c1 = self.my_columns
        symbol_columns = np.asarray(symbol_columns, dtype=float)
        if symbol_columns.shape != (self.lengths[0], c1 - c0):
            raise ValueError(f"symbol block has shape {symbol_columns.shape}, expected "
                             f"{(self.lengths[0], c1 - c0)}")
        half = self._half_rows
        mirrored = symbol_columns[half:]
        if mirrored.size:
            scale = float(np.abs(symbol_columns).max())
            odd = float(np.abs(mirrored - self._mirror(symbol_columns)).max())
            if not odd <= EVEN_TOLERANCE * scale:
                raise ValueError(f"the symbol is not even in kx (rows k and Lx - k differ by {odd:.3e} "
                                 f"of a largest value {scale:.3e}): the kernel must be even")
        self._half = np.ascontiguousarray(symbol_columns[:half])
        self._single_half = None

    @property
    def _half_rows(self) -> int:
        """The rows of the symbol kept: kx = 0 … Lx // 2; row Lx − k is row k's mirror."""
        return self.lengths[0] // 2 + 1

    def _mirror(self, rows: np.ndarray) -> np.ndarray:
        """The rows kx = Lx // 2 + 1 … Lx − 1 of an even symbol from its rows kept (or from all of
        them): rows Lx − kx, a view with the rows reversed."""
        return rows[self.lengths[0] - self._half_rows:0:-1]

    @property
    def symbol(self) -> np.ndarray | None:
        """The symbol on this rank's columns, all Lx rows (a new array made from the rows kept;
        None before it is set)."""
        if self._half is None:
            return None
        return np.concatenate([self._half, self._mirror(self._half)])

    @contextmanager
    def inverted(self):
        """Products with 1 / symbol inside the block, the symbol's own after it: a
        preconditioner that keeps C⁻¹ applies C this way (:mod:`.balancing`). The inverse is made
        on entry and let go on exit (N/4 values of this rank's columns)."""
        kept = self._half, self._single_half
        self._half, self._single_half = 1.0 / kept[0], None
        try:
            yield self
        finally:
            self._half, self._single_half = kept

    def release_symbol(self) -> None:
        """Forget the symbol (an owner that keeps symbols of its own, :mod:`.shear`)."""
        self._half = self._single_half = None

    # --------------------------------------------------------------- product
    def apply(self, field: np.ndarray, single: bool = False) -> np.ndarray:
        """k ⊛ field on this rank's rows: ``field`` and the result have shape (rows, ny);
        ``single``: computed in single precision (the result is float32)."""
        return self._filtered(self.forward(field, single), single)

    def apply_at(self, values, positions: np.ndarray, single: bool = False) -> np.ndarray:
        """k ⊛ x for x equal to ``values`` at the flat ``positions`` of this rank's (rows, ny) slab
        and zero elsewhere; the result as from :meth:`apply`. A sparse x (a contact set) goes
        straight into the padded rows buffer, where only the positions of the last such call are
        cleared: that saves zeroing a slab of N values and copying it in. An x at more than one
        node in DENSE_WRITE is scattered into a flat slab and copied in."""
        return self._filtered(self._transform_at(values, positions, single), single)

    def apply_written(self, write, single: bool = False) -> np.ndarray:
        """k ⊛ x for the x that ``write(block)`` writes into ``block``, this rank's (rows, ny) part
        of the padded rows buffer, every value of it (it holds the last product's): :meth:`apply`
        without the field's copy into the buffer, the caller's last pass writing there instead.
        The product uncropped, the whole width Ly of this rank's rows (a contiguous array; the
        grid's columns are its first ny)."""
        block = self._padded(single)[0][:, :self.shape[1]]
        self._written[single] = None                # the whole block: zeroed whole next (even if write fails)
        write(block)
        return self._filtered(self._transform(single), single, crop=False)

    def held(self, field: np.ndarray, single: bool = False) -> HeldProduct:
        """:meth:`apply` stopped before its inverse transforms, with xᵀ(k ⊛ x) read off the
        spectrum (:class:`HeldProduct`)."""
        return self._held(self.forward(field, single), single)

    def held_at(self, values, positions: np.ndarray, single: bool = False) -> HeldProduct:
        """:meth:`apply_at` stopped before its inverse transforms, as :meth:`held`."""
        return self._held(self._transform_at(values, positions, single), single)

    def _held(self, spectrum: np.ndarray, single: bool) -> HeldProduct:
        # Parseval over the half spectrum of a real field: every column ky stands for itself and
        # its conjugate but ky = 0 and ky = Ly / 2 (Ly even), which stand for themselves only
        c0, c1 = self.my_columns
        ly = self.lengths[1]
        once = [c - c0 for c in ({0, ly // 2} if ly % 2 == 0 else {0}) if c0 <= c < c1]
        counted_once = 0.0
        if once:
            # the symbol the product scales by (float32 in single precision): rows kx = 0 … Lx // 2
            # by its rows kept, the others by their mirror
            kept = self._half[:, once].astype(np.float32 if single else float)
            symbol = np.concatenate([kept, self._mirror(kept)])
            counted_once = float(np.sum(symbol * np.abs(spectrum[:, once].astype(complex)) ** 2))
        total = self._scaled(spectrum, single, summed=True)
        energy = (2.0 * total - counted_once) / (self.lengths[0] * ly)
        return HeldProduct(self, spectrum, energy, self._stamp)

    def restricted(self, values, positions: np.ndarray, single: bool = False) -> np.ndarray:
        """(k ⊛ x) at the flat ``positions`` of this rank's (rows, ny) slab for x equal to
        ``values`` there and zero elsewhere (R_S K R_Sᵀ on a set S), read off the product before
        it is cropped to the grid: on a period longer than the grid the crop is strided, and
        reading it flat copied the whole slab (67 MB a call at 4096² in single precision). A
        dense x is read back through the columns buffer, free once the product is made."""
        whole = self._filtered(self._transform_at(values, positions, single), single, crop=False)
        index = self._written[single]
        if index is not None:
            return passes.gather(whole.reshape(-1), index, self.workers)
        # written dense (the write made sure the buffer holds the slab); the product is a new array
        flat = _flat_slab(*self._padded(single), whole.shape[0] * self.shape[1])
        passes.copy(flat.reshape(whole.shape[0], -1), whole[:, :self.shape[1]], self.workers)
        return passes.gather(flat, positions, self.workers)

    def _transform_at(self, values, positions: np.ndarray, single: bool) -> np.ndarray:
        """The transform of ``values`` at the slab ``positions`` and zeros elsewhere, written as
        :meth:`_written_at` writes them and only their rows transformed along y."""
        return self._transform(single, self._written_at(values, positions, single))

    def _written_at(self, values, positions: np.ndarray, single: bool) -> np.ndarray:
        """Write ``values`` at the slab ``positions`` into the zeroed rows buffer of one precision;
        the mask of the rows that hold them. Where the positions are more than one node in
        DENSE_WRITE of the slab, the values are scattered into the columns buffer seen as a flat
        slab (the transform writes it whole before reading it) and copied into the rows: near
        full contact at 2048² (86 % of the nodes) the padded indices, a division and a modulo of
        each position, took more than half of the 22 ms a write took."""
        rows, columns = self._padded(single)
        count, ny, ly = rows.shape[0], self.shape[1], self.lengths[1]
        block = rows[:, :ny]
        flat = _flat_slab(rows, columns, count * ny) if dense(positions.size, count * ny) else None
        if flat is not None:
            passes.fill(flat.reshape(count, ny), 0.0, self.workers)
            passes.scatter(flat, positions, values, self.workers)
            passes.copy(block, flat.reshape(count, ny), self.workers)
            self._written[single] = None                    # the whole block: zeroed whole next
            return block.any(axis=1)
        last = self._written.get(single)
        if last is None or dense(last.size, count * ny):
            passes.fill(block, 0.0, self.workers)
        else:
            passes.scatter(rows.reshape(-1), last, 0.0, self.workers)
        row = positions // ny
        if ly == ny:
            index = positions.copy()                     # kept to clear them: not the caller's array
        else:
            index = row * (ly - ny)
            index += positions
        passes.scatter(rows.reshape(-1), index, values, self.workers)
        self._written[single] = index
        occupied = np.zeros(count, dtype=bool)
        occupied[row] = True
        return occupied

    def _filtered(self, spectrum: np.ndarray, single: bool, crop: bool = True) -> np.ndarray:
        """The product from the field's transform: times the symbol, transformed back.

        The rows kx = 0 … Lx // 2 are scaled by the symbol's rows kept, the others by their
        mirror (a view with rows reversed). In single precision the spectrum is scaled as float32
        pairs by the symbol's values each written twice: complex64 times a float32 symbol
        converted each value on the fly, 1.3–1.4 times as long (a 2048² padded product's 4096 × 2049
        spectrum: 15.2 and 15.4 against 11.7 and 11.1 ms, medians of 11)."""
        self._scaled(spectrum, single)
        return self.backward(spectrum, crop)

    def _scaled(self, spectrum: np.ndarray, single: bool, summed: bool = False) -> float | None:
        """The spectrum times the symbol, in place (:meth:`_filtered`); ``summed``: also Σ λ |X|²
        over it (:func:`.passes.scale_summed`), else None."""
        if single:
            if self._single_half is None:
                # each value written twice, as numpy's repeat of the float32 symbol, by two strided
                # copies on the workers (repeat took 0.43 s of a 4096² solve's 37.9 s)
                self._single_half = np.empty((self._half.shape[0], 2 * self._half.shape[1]), dtype=np.float32)
                for part in (0, 1):
                    passes.copy(self._single_half[:, part::2], self._half, self.workers)
            # the transforms' spectra are contiguous along their columns, which the view needs
            symbol, scaled = self._single_half, spectrum.view(np.float32)
        else:
            symbol, scaled = self._half, spectrum
        half = self._half_rows
        if not summed:
            passes.scale(scaled[:half], symbol, self.workers)
            passes.scale(scaled[half:], self._mirror(symbol), self.workers)
            return None
        return (passes.scale_summed(scaled[:half], symbol, self.workers)
                + passes.scale_summed(scaled[half:], self._mirror(symbol), self.workers))

    def forward(self, field: np.ndarray, single: bool = False) -> np.ndarray:
        """2-D transform of the (padded) field: this rank's frequency columns, (Lx, my columns).

        The padding lives in two buffers kept between calls (the padded rows and
        the padded columns), transformed in place: scipy would otherwise allocate
        and zero a padded copy at every call (8 % of a 2048² product).
        """
        rows = self._padded(single)[0]
        passes.copy(rows[:, :self.shape[1]], field, self.workers)
        self._written[single] = None
        return self._transform(single)

    def _padded(self, single: bool) -> tuple[np.ndarray, np.ndarray]:
        """The padded rows and columns buffers of one precision, made on first use.

        Both precisions share one storage, made for the widest precision asked for so far (a
        4096² rank's single buffers are 0.4 GB): the single buffers are the first half of the
        double ones' bytes. A product of the other precision leaves its values (and, across the
        single rows' padding, garbage) there, so the first product after a change of precision
        zeroes its rows buffer whole (about 4 changes per solve; the columns buffer is written
        whole by every transform).
        """
        if single not in self._buffers:
            if self._storage is None or (not single and self._storage[0].dtype != np.float64):
                real, spectral = (np.float32, np.complex64) if single else (np.float64, np.complex128)
                self._storage = (np.zeros((self.rows[1] - self.rows[0], self.lengths[1]), dtype=real),
                                 np.zeros((self.lengths[0], self.my_columns[1] - self.my_columns[0]),
                                          dtype=spectral))
                self._buffers.clear()
                self._written.clear()
                self._holder = None                                 # zeros: right for either
            rows, columns = self._storage
            self._buffers[single] = (_leading(rows, np.float32), _leading(columns, np.complex64)) \
                if single and rows.dtype == np.float64 else (rows, columns)
            self._written[single] = None
        buffers = self._buffers[single]
        if self._holder is not None and self._holder != single:
            passes.fill(buffers[0], 0.0, self.workers)
            self._written[single] = np.zeros(0, dtype=np.intp)     # nothing of this precision left
        self._holder = single
        return buffers

    def _transform(self, single: bool, occupied: np.ndarray | None = None) -> np.ndarray:
        """The 2-D transform of the rows buffer of one precision as it stands; ``occupied``: a
        mask of the rows that may hold values (the others are zero), or None for all.

        Where the rows left out outweigh the calls (:data:`RUN_POINTS`), only the runs of
        occupied rows are transformed along y and the other rows' spectra are zeros: the contact
        set of the large-grid scene at 4096² lies on 47 % of the rows, the forces a cut restores
        on 0.3-44 %.
        """
        rows, columns = self._buffers[single]
        self._stamp += 1
        count = rows.shape[0]
        runs = _runs(occupied) if occupied is not None and count else None
        if runs is None or (count - np.count_nonzero(occupied)) * self.lengths[1] <= RUN_POINTS * len(runs):
            self._to_columns(sfft.rfft(rows, axis=1, workers=self.workers), out=columns)
        else:
            # one rank: straight into the columns buffer, whose first nx rows are its rows
            spectra = columns[:count] if self.size == 1 else np.empty((count, self.columns), columns.dtype)
            done = 0
            for start, stop in runs:
                passes.fill(spectra[done:start], 0.0, self.workers)
                passes.copy(spectra[start:stop], sfft.rfft(rows[start:stop], axis=1, workers=self.workers),
                            self.workers)
                done = stop
            passes.fill(spectra[done:], 0.0, self.workers)
            if self.size > 1:
                self._to_columns(spectra, out=columns)
        passes.fill(columns[self.shape[0]:], 0.0, self.workers)
        return sfft.fft(columns, axis=0, overwrite_x=True, workers=self.workers)

    def release_buffers(self) -> None:
        """Free the padded buffers of :meth:`forward` (made again on the next product): a coarse
        level idle while the fine grid solves need not hold them."""
        self._storage = None
        self._buffers.clear()
        self._written.clear()
        self._holder = None

    def backward(self, spectrum: np.ndarray, crop: bool = True) -> np.ndarray:
        """Inverse of :meth:`forward`, cropped to the grid: this rank's rows, (rows, ny); with
        ``crop`` False the whole width Ly of those rows (a contiguous array)."""
        nx, ny = self.shape
        columns = sfft.ifft(spectrum, axis=0, overwrite_x=True, workers=self.workers)[:nx]
        spectra = self._to_rows(columns)
        rows = sfft.irfft(spectra, n=self.lengths[1], axis=1, overwrite_x=True, workers=self.workers)
        return rows[:, :ny] if crop else rows

    # ------------------------------------------------------------ transposes
    # Both are one MPI_Alltoallw: the blocks of the rows' side, strided (each row's run of a rank's
    # columns), go out and come in through vector datatypes, and the columns' side is read and
    # written in place; no packed copy of either side is made (two temporaries of the rank's
    # spectrum per transpose when they were packed: 2 ranks held 18 % more than half of one).
    def _to_columns(self, spectra: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(my rows, all columns) → (all rows, my columns), into ``out`` (its first nx rows) if given."""
        if self.size == 1:
            if out is None:
                return spectra
            passes.copy(out[:self.shape[0]], spectra, self.workers)
            return out[:self.shape[0]]
        width = self.my_columns[1] - self.my_columns[0]
        if out is None:
            out = np.empty((self.shape[0], width), dtype=spectra.dtype)
        spectra = np.ascontiguousarray(spectra)
        self._exchange(rows=spectra, columns=out, to_columns=True)
        return out[:self.shape[0]]

    def _to_rows(self, columns: np.ndarray) -> np.ndarray:
        """(all rows, my columns) → (my rows, all columns)."""
        if self.size == 1:
            return columns
        columns = np.ascontiguousarray(columns)
        out = np.empty((self.rows[1] - self.rows[0], self.columns), dtype=columns.dtype)
        self._exchange(rows=out, columns=columns, to_columns=False)
        return out

    def _exchange(self, rows: np.ndarray, columns: np.ndarray, to_columns: bool) -> None:
        """Alltoallw between this rank's (my rows, all columns) array ``rows`` and its (≥ nx rows,
        my columns) array ``columns``, C-ordered, in the direction ``to_columns``."""
        from mpi4py.util.dtlib import from_numpy_dtype

        base = from_numpy_dtype(rows.dtype)
        item = rows.dtype.itemsize
        my_rows = rows.shape[0]
        width = columns.shape[1]
        strided, strided_displ, created = [], [], []
        for c0, c1 in self.column_blocks:
            if my_rows and c1 > c0:
                kind = base.Create_vector(my_rows, c1 - c0, self.columns).Commit()
                created.append(kind)
                strided.append(kind)
            else:
                strided.append(base)
            strided_displ.append(c0 * item)
        strided_counts = [1 if (my_rows and c1 > c0) else 0 for c0, c1 in self.column_blocks]
        block_counts = [(r1 - r0) * width for r0, r1 in self.row_blocks]
        block_displ = [r0 * width * item for r0, r1 in self.row_blocks]
        blocks = [base] * self.size
        row_side = [rows, (strided_counts, strided_displ), strided]
        column_side = [columns, (block_counts, block_displ), blocks]
        try:
            if to_columns:
                self.comm.Alltoallw(row_side, column_side)
            else:
                self.comm.Alltoallw(column_side, row_side)
        finally:
            for kind in created:
                kind.Free()


class HeldProduct:
    """k ⊛ x stopped between its transforms: the spectrum of x times the symbol, left in the
    convolution's columns buffer, and ``energy``, this rank's part of xᵀ(k ⊛ x) over the grid
    (twice the elastic energy of forces x), read off that spectrum by Parseval's theorem (x is
    zero off the grid, so the padded circular
    product's quadratic form is the linear one's). The constrained CG needs dᵀHd of a search
    direction before it knows whether the step's own H d is wanted or only H of the step and
    its cut together (:mod:`roughcontact.normal.constrained_cg`): a product left held skips its
    inverse transforms, half its cost. :meth:`result` completes it; any later transform of the
    convolution overwrites the buffer, and result() then raises."""

    def __init__(self, convolution: SlabConvolution, spectrum: np.ndarray, energy: float, stamp: int):
        self.convolution = convolution
        self.spectrum = spectrum
        self.energy = energy
        self._stamp = stamp

    def result(self) -> np.ndarray:
        """k ⊛ x as :meth:`SlabConvolution.apply` gives it (once: the inverse overwrites the spectrum)."""
        if self.spectrum is None or self.convolution._stamp != self._stamp:
            raise RuntimeError("a held product was completed twice, or after another transform of "
                               "its convolution overwrote its spectrum")
        spectrum, self.spectrum = self.spectrum, None
        return self.convolution.backward(spectrum)


def _folded(length: int) -> np.ndarray:
    """|offset| of each position of a period: min(d, L − d) for d = 0 … L − 1."""
    d = np.arange(length)
    return np.minimum(d, length - d)


def _runs(mask: np.ndarray) -> np.ndarray:
    """(start, stop) of each run of True in a 1-D boolean mask, shape (runs, 2)."""
    edges = np.flatnonzero(np.diff(mask.view(np.int8), prepend=np.int8(0), append=np.int8(0)))
    return edges.reshape(-1, 2)


def _flat_slab(rows: np.ndarray, columns: np.ndarray, size: int) -> np.ndarray | None:
    """The first ``size`` values of the columns buffer seen as reals of the rows buffer's dtype, or
    None where it holds fewer (a rank with few columns; free between products: every transform
    writes it whole first)."""
    if not columns.flags.c_contiguous:
        return None
    flat = columns.reshape(-1).view(rows.dtype)
    return flat[:size] if flat.size >= size else None


def _leading(block: np.ndarray, dtype) -> np.ndarray:
    """The first bytes of C-contiguous ``block`` seen as an array of its shape and the narrower
    ``dtype`` (the single-precision buffer inside the double one's storage)."""
    return block.reshape(-1).view(dtype)[:block.size].reshape(block.shape)
