"""The flexibility operator of one footprint: its PETSc Mat, full products, blocks on a contact set.

Every solver sees H through a :class:`Flexibility`:

- :attr:`Flexibility.mat`, a PETSc Mat on the communicator it was given:
  the explicit MATDENSE (``kind = "dense"``, Eq. 10 rows) or a matrix-free
  Python Mat (``"fft"``: the Eq. 10 kernel applied by a zero-padded FFT
  convolution; ``"fft-periodic"``: the kernel summed over the images of a
  periodic cell, :mod:`.periodic`);
- :meth:`Flexibility.product`: H x over the whole footprint by FFT for
  every kind (the same numbers as the dense product to round-off, at
  O(N log N) instead of O(N²)), used for every gap evaluation; but for a
  dense operator on a footprint that is a small part of its grid (a
  contact set), whose matrix product is cheaper than the FFT over the grid
  (:func:`explicit_products_pay`);
- :meth:`Flexibility.block`: H_SS on a contact set S for the Krylov inner
  solves: an explicit matrix gathered from the Eq. 10 table when S is small
  enough that its dense product is cheaper than an FFT, otherwise the
  matrix-free restriction (zero outside S, full convolution, read on S);
- :meth:`Flexibility.precondition`: the Fourier preconditioner of the
  contact set, z_S = [C⁻¹ (g on S, 0 elsewhere)]_S with C the circulant of
  the kernel folded onto a period a little longer than the grid (the grid's
  own for the periodic operator; :mod:`.preconditioner`).

A user's own Mat is accepted with :meth:`Flexibility.from_mat`; products
then use its ``mult`` and blocks its ``createSubMatrix``.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..errors import InputError
from ..threads import blas_threads
from . import passes
from .convolution import SlabConvolution
from .kernel import kernel_block, punch_block, punch_kernel
from .layout import NodeLayout
from .memory import EXPLICIT_BYTES, EXPLICIT_RATIO, KINDS, TABLE_BYTES


def explicit_within(count: int, largest: int, nodes: int, entry_bytes: int) -> bool:
    """Whether an explicit block of ``count`` nodes is within the bounds of explicit matrices:
    count² ≤ EXPLICIT_RATIO · ``nodes`` (the nodes whose FFT product it stands in for), and the
    rank with the ``largest`` share of its rows holds at most EXPLICIT_BYTES of them, at
    ``entry_bytes`` an entry."""
    return count * count <= EXPLICIT_RATIO * nodes and entry_bytes * count * largest <= EXPLICIT_BYTES


def sparse_footprint(layout: NodeLayout) -> bool:
    """Whether the footprint holds at most an eighth of its grid's nodes: the dense matrix's entries
    are then read from the Eq. 10 table node by node (:func:`~.kernel.kernel_block`, 0.19 s for
    the 3 731 nodes of a 513² grid's contact set), not as the windows of
    :func:`~.dense.assemble_flexibility`, which read the whole grid for each node of a footprint
    whose rows are not whole (0.72 s there)."""
    return 8 * layout.size <= layout.shape[0] * layout.shape[1]


def explicit_products_pay(layout: NodeLayout, comm) -> bool:
    """Whether a dense operator's products on a sparse footprint (:func:`sparse_footprint`) go
    through its matrix rather than the FFT over the grid (collective): while
    N² ≤ EXPLICIT_RATIO · nx ny (N the footprint's nodes) and the rank with the most
    rows holds at most EXPLICIT_BYTES of them in double and single precision (the same on every
    rank). On the 3 731 contact nodes of a 513² grid (N² = 53 nx ny) a product took 1.5 ms in
    single precision and 4.3 ms in double (two BLAS threads; 3.0 and 7.9 ms on one), the padded
    FFT product 9.0 and 15.0 ms (medians of 21). A whole
    grid, or a footprint of more than an eighth of it, keeps the FFT's products."""
    largest = max(comm.allgather(layout.local_size))
    return explicit_within(layout.size, largest, layout.shape[0] * layout.shape[1], 12)


class Flexibility:
    """H (Eqs. 9–11) over the footprint of a topography, distributed over ``comm``.

    Parameters
    ----------
    topography
        Composite topography (grid, spacing, footprint).
    interface
        The materials (composite compliance A, Eq. 4a).
    comm
        mpi4py communicator.
    kind
        ``"dense"``, ``"fft"`` or ``"fft-periodic"`` (the grid is one period
        of a periodic surface; the footprint must be the whole grid).
    workers
        FFT threads per rank (default: the cores of the node shared by its ranks).
    """

    def __init__(self, topography, interface, comm, kind: str = "fft", workers: int | None = None):
        if kind not in KINDS:
            raise InputError("operator", f"must be one of {', '.join(KINDS)}, got {kind!r}")
        self.kind = kind
        self.comm = comm
        self.periodic = kind == "fft-periodic"
        self.layout = NodeLayout.build(topography, comm)
        self.shape = self.layout.shape
        if self.periodic and not self.layout.whole_grid:
            raise InputError("operator", "'fft-periodic' needs the whole grid as footprint (one period "
                                         "of a periodic surface); use 'fft' for a bounded footprint")
        self.spacing = topography.spacing
        self.compliance = interface.compliance
        self.convolution = SlabConvolution(self.shape, comm, periodic=self.periodic, workers=workers)
        self._table = None
        r0, r1 = self.layout.rows
        #: products by the explicit matrix rather than the FFT (:meth:`product`)
        sparse = kind == "dense" and sparse_footprint(self.layout)
        self.explicit_products = sparse and explicit_products_pay(self.layout, comm)
        # the FFT's symbol, of the whole grid, is made when a transform first needs it: explicit
        # products need none
        self._kernel_set = False
        if self.periodic:
            table = self._whole_table()              # the Ewald sum makes the whole period at once
            self.convolution.set_kernel(table[r0:r1])
            self._kernel_set = True
            self.diagonal = float(table[0, 0])
        else:
            if not self.explicit_products:
                self._set_kernel()
            self.diagonal = float(punch_kernel((1, 1), self.spacing, self.compliance)[0, 0])
        self._preconditioner = None
        self._near_field = None                       # NearField, False where none applies
        # the slab a product writes a footprint's nodes into; whole rows are their own slab (a view)
        self._slab = None if self.layout.whole_rows else np.zeros((r1 - r0, self.shape[1]))
        self._single_rows = None
        # every rank's nodes, for the x an explicit product gathers
        self._counts = np.array(comm.allgather(self.layout.local_size)) if self.explicit_products else None
        if sparse:
            # a footprint that is a small part of its grid: its entries read from the table node
            # by node (the windows of the assembly below read the whole grid for each node)
            self.mat = self._explicit_block(np.ones(self.layout.local_size, bool), self.layout.size)
        elif kind == "dense":
            from .dense import assemble_flexibility

            # the assembly reads every node's position: a footprint held by rows is gathered (N bytes,
            # on the small grids the dense operator is for)
            self.mat = assemble_flexibility(self.table, self.layout.with_footprint(comm), comm)
        else:
            from .fft import full_operator

            self.mat = full_operator(self)

    @classmethod
    def from_mat(cls, mat: PETSc.Mat, topography, comm) -> "Flexibility":
        """Wrap a user's Mat for H over the footprint (rows as :class:`~.layout.NodeLayout`)."""
        self = cls.__new__(cls)
        self.kind = f"user ({mat.getType()})"
        self.comm = comm
        self.periodic = False
        self.layout = NodeLayout.build(topography, comm)
        self.shape = self.layout.shape
        self.spacing = topography.spacing
        self.convolution = self._table = self._preconditioner = None
        self._slab = self._near_field = self._single_rows = None
        self._kernel_set = False
        self.explicit_products = False
        self._counts = None
        self.mat = mat
        rows = tuple(mat.getOwnershipRange())
        if mat.getSize()[0] != self.layout.size or rows != (self.layout.start, self.layout.stop):
            raise InputError("operator", f"has {mat.getSize()[0]} rows owned {rows} on this rank; the footprint "
                                         f"has {self.layout.size} nodes owned "
                                         f"({self.layout.start}, {self.layout.stop}) (blocks of grid rows)")
        diagonal = mat.getDiagonal()
        self.diagonal = float(diagonal.max()[1])
        diagonal.destroy()
        return self

    @property
    def table(self) -> np.ndarray | None:
        """The whole Eq. 10 table K[|Δi|, |Δj|] (the periodic operator: its kernel on one period),
        built on first use and kept — by the dense matrix and by explicit blocks up to
        TABLE_BYTES, as it holds N entries on every rank; None for a user's Mat."""
        if self._table is None and self.convolution is not None:
            self._table = self._whole_table()
        return self._table

    def _whole_table(self) -> np.ndarray:
        if self.periodic:
            from .periodic import periodic_kernel

            return periodic_kernel(self.shape, self.spacing, self.compliance)
        return punch_kernel(self.shape, self.spacing, self.compliance)

    # -------------------------------------------------------------- products
    def product(self, values: np.ndarray, single: bool = False) -> np.ndarray:
        """H x on this rank's nodes, for x given on this rank's nodes (whole footprint);
        ``single``: the FFT in single precision (relative error ~1e-7, :mod:`.convolution`;
        explicit products in float32; a user's Mat ignores it), the result still float64."""
        if self.explicit_products:
            return self._explicit_product(values, single)
        if self.convolution is None:
            x, y = self.mat.createVecs()
            x.getArray()[:] = values
            self.mat.mult(x, y)
            out = y.getArray().copy()
            x.destroy()
            y.destroy()
            return out
        return self._nodal(self.convolution.apply(self.slab(values), single))

    def slab(self, values: np.ndarray) -> np.ndarray:
        """This rank's grid rows of nodal ``values``, zero off the footprint: a view where the rows
        are whole, else the operator's own scratch slab (overwritten by the next call or product)."""
        return self.layout.to_slab(values, out=self._slab)

    def product_at(self, values: np.ndarray, nodes: np.ndarray, single: bool = False) -> np.ndarray:
        """H x on this rank's nodes for x equal to ``values`` on this rank's ``nodes`` (local
        indices) and zero elsewhere, as :meth:`product`: a sparse x (a search direction on the
        free set, the forces a cut restores) goes into the transform without a vector of N."""
        if self.convolution is None or self.explicit_products:
            full = np.zeros(self.layout.local_size)
            full[nodes] = values
            return self.product(full, single)
        return self._nodal(self.convolution.apply_at(values, self.layout.slab_positions(nodes), single))

    def _explicit_product(self, values: np.ndarray, single: bool) -> np.ndarray:
        """H x by this rank's rows of the explicit matrix and every rank's x (collective);
        ``single``: rows and x in float32 (the rows' float32 copy made on first use)."""
        rows = np.asarray(self.mat.getDenseArray(readonly=True))      # (local, N), a view
        if single:
            if self._single_rows is None:
                self._single_rows = rows.astype(np.float32)
            rows = self._single_rows
        whole = np.ascontiguousarray(values, dtype=rows.dtype)       # one rank: its x is all of x
        if self.comm.Get_size() > 1:
            local, whole = whole, np.empty(self.layout.size, dtype=rows.dtype)
            self.comm.Allgatherv(local, [whole, self._counts])
        # the rank's transform threads (one per rank where the ranks share the node's cores)
        with blas_threads(self.workers):
            return (rows @ whole).astype(float, copy=False)

    @property
    def workers(self) -> int:
        """Threads of this rank's transforms, and of its explicit products."""
        return self.convolution.workers if self.convolution is not None else 1

    @property
    def holds(self) -> bool:
        """Whether a product can be held between its transforms (:meth:`held_product`): not on a
        user's Mat, which has none, nor where products are explicit."""
        return self.convolution is not None and not self.explicit_products

    def held_product(self, values: np.ndarray, single: bool = False) -> HeldNodal:
        """:meth:`product` held between its transforms, with xᵀHx known (:class:`HeldNodal`)."""
        return HeldNodal(self, self._convolution_of("held products").held(self.slab(values), single))

    def held_product_at(self, values: np.ndarray, nodes: np.ndarray, single: bool = False) -> HeldNodal:
        """:meth:`product_at` held between its transforms, as :meth:`held_product`."""
        return HeldNodal(self, self._convolution_of("held products").held_at(
            values, self.layout.slab_positions(nodes), single))

    def _convolution_of(self, what: str) -> SlabConvolution:
        if self.convolution is None:
            raise InputError("operator", f"{what} need an operator built from a topography, not a user Mat")
        if not self._kernel_set:
            self._set_kernel()
        return self.convolution

    def _set_kernel(self) -> None:
        """The convolution's symbol from this rank's rows of the Eq. 10 table (collective): no array
        of N entries on every rank."""
        r0, r1 = self.layout.rows
        self.convolution.set_kernel(punch_kernel(self.shape, self.spacing, self.compliance,
                                                 rows=np.arange(r0, r1), workers=self.convolution.workers))
        self._kernel_set = True

    def _nodal(self, result: np.ndarray) -> np.ndarray:
        """This rank's nodes of a product on its slab rows, float64, a new contiguous array."""
        if self.layout.whole_rows:
            if result.dtype == np.float64 and result.flags.c_contiguous:
                return result.reshape(-1)              # the transform's own new array, uncropped
            # one copy of the cropped (strided) product, cast to float64 on the way: reshaping it
            # first made a float32 copy and the cast a second one (5 ms of a 100 ms product at
            # 2048²); shared by the transform's threads (:mod:`.passes`)
            out = np.empty(result.shape)
            passes.copy(out, result, self.convolution.workers)
            return out.reshape(-1)
        return self.layout.from_slab(result).astype(float, copy=False)

    def precondition_nodes(self, values: np.ndarray, nodes: np.ndarray, single: bool = False,
                           edge: np.ndarray | None = None) -> np.ndarray:
        """z = [C⁻¹ (values on S, 0 elsewhere)]_S: the Fourier preconditioner of H_SS, S given by
        this rank's node indices, ``values`` and result on S only; ``single`` as :meth:`product`;
        ``edge``: the edge correction's weights on S, subtracted (:mod:`.preconditioner`)."""
        return self.preconditioner.apply_nodes(values, nodes, single, edge)

    def release_buffers(self) -> None:
        """Free the transform buffers of the operator and its preconditioner until their next use."""
        if self.convolution is not None:
            self.convolution.release_buffers()
        if self._preconditioner is not None:
            self._preconditioner.convolution.release_buffers()

    @property
    def preconditioner(self):
        """The Fourier preconditioner of contact-set blocks (:mod:`.preconditioner`), built on first use."""
        if self._preconditioner is None:
            from .preconditioner import FourierPreconditioner

            if self.convolution is None:
                raise InputError("pc", "the Fourier preconditioner needs an operator built from a "
                                       "topography ('dense', 'fft', 'fft-periodic'), not a user Mat")
            self._preconditioner = FourierPreconditioner(self)
        return self._preconditioner

    @property
    def near_field(self):
        """Direct sums of the kernel near a few forces (:mod:`.near_field`), built on first use;
        None where they do not apply (a periodic operator, a user's Mat, a footprint that is not
        the whole grid). The same decision on every rank."""
        if self.convolution is None or self.explicit_products:
            return None
        if self._near_field is None:
            from .near_field import NearField

            self._near_field = NearField(self) if NearField.applies(self) else False
        return self._near_field or None

    # ---------------------------------------------------------------- blocks
    def explicit_fits(self, count: int, largest: int) -> bool:
        """Whether an explicit H_SS of ``count`` nodes, ``largest`` of them on one rank, is cheaper
        than FFT products and fits (:data:`~.memory.EXPLICIT_RATIO`, :data:`~.memory.EXPLICIT_BYTES`:
        the rank with the most of S holds its rows of the block)."""
        return explicit_within(count, largest, self.layout.size, 8)

    def block(self, active: np.ndarray, explicit: bool | None = None, single: bool = False) -> PETSc.Mat:
        """H_SS for the contact set S (``active``: mask over this rank's nodes), a new Mat.

        ``explicit`` forces an explicit (True) or matrix-free (False) block;
        by default the cheaper one (:meth:`explicit_fits`). ``single``: a matrix-free block's
        products in single precision (:meth:`product`).
        """
        if self.kind == "dense" or self.convolution is None:
            rows = (np.flatnonzero(active) + self.layout.start).astype(PETSc.IntType)
            index_set = PETSc.IS().createGeneral(rows, comm=self.comm)
            sub = self.mat.createSubMatrix(index_set, index_set)
            index_set.destroy()
            return sub
        counts = self.comm.allgather(int(active.sum()))
        count = sum(counts)
        if explicit is None:
            explicit = self.explicit_fits(count, max(counts))
        if explicit:
            return self._explicit_block(active, count)
        from .fft import restricted_operator

        return restricted_operator(self, active, single)

    def _explicit_block(self, active: np.ndarray, count: int) -> PETSc.Mat:
        """H_SS from Eq. 10, row-distributed MATDENSE (C-ordered columns)."""
        local_nodes = self.layout.local_nodes()[active]
        all_nodes = np.concatenate(self.comm.allgather(local_nodes))
        # H_SS is symmetric: row j of this C-ordered array is column j of the local rows
        columns = self._entries(all_nodes, local_nodes)
        local = local_nodes.shape[0]
        mat = PETSc.Mat().createDense(((local, count), (local, count)), array=columns.T, comm=self.comm)
        mat.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        mat.setOption(PETSc.Mat.Option.SPD, True)
        mat.assemble()
        return mat

    def _entries(self, row_nodes: np.ndarray, column_nodes: np.ndarray) -> np.ndarray:
        """H between two sets of (i, j) nodes: read from the Eq. 10 table while it takes at most
        TABLE_BYTES (the periodic operator's Ewald-summed period always: there is no entry-wise
        formula; its set-up lets its own copy go, so a first block sums the period again — no
        solver of the periodic operator takes blocks: rotations and the active set refuse it),
        else Eq. 10 evaluated at each entry."""
        if self.periodic or 8 * self.shape[0] * self.shape[1] <= TABLE_BYTES:
            return kernel_block(self.table, self.shape, row_nodes, column_nodes, periodic=self.periodic)
        return punch_block(self.spacing, self.compliance, row_nodes, column_nodes)

    def destroy(self) -> None:
        """Free the PETSc Mat (collective)."""
        if self.mat is not None:
            self.mat.destroy()
        self.mat = self._single_rows = None


class HeldNodal:
    """H x on this rank's nodes held before its inverse transforms
    (:class:`~.convolution.HeldProduct`): ``energy`` is this rank's part of xᵀHx, :meth:`result`
    completes H x."""

    def __init__(self, flexibility: Flexibility, held):
        self.flexibility = flexibility
        self.held = held
        self.energy = held.energy

    def result(self) -> np.ndarray:
        """H x on this rank's nodes, float64, as :meth:`Flexibility.product` gives it (once)."""
        return self.flexibility._nodal(self.held.result())
