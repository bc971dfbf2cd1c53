"""FFT flexibility operators: the same numbers as the dense Eq. 10 matrix, on any layout.

Run serially and under ``mpiexec -n 2``; a three-rank case runs in a subprocess.
"""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from roughcontact.materials import Interface, Material
from roughcontact.operators import passes
from roughcontact.operators.flexibility import Flexibility
from roughcontact.operators.kernel import influence_rows, kernel_block, punch_kernel
from roughcontact.operators.periodic import lattice_coulomb, periodic_kernel
from roughcontact.surfaces import Topography, disc

from conftest import table_block, traced_peak

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
SPACING = 1e-4


def topography(n: int, footprint: str) -> Topography:
    heights = np.zeros((n, n))
    mask = disc((n, n), SPACING, 0.9 * n * SPACING) if footprint == "disc" else None
    return Topography(heights, SPACING, mask)


def vectors(mat: PETSc.Mat, values: np.ndarray):
    x, y = mat.createVecs()
    start, stop = mat.getOwnershipRange()
    x.getArray()[:] = values[start:stop]
    return x, y


def gathered(comm, vec) -> np.ndarray:
    return np.concatenate(comm.allgather(vec.getArray().copy()))


@pytest.mark.parametrize("n", [32, 64])
@pytest.mark.parametrize("footprint", ["square", "disc"])
def test_fft_product_equals_dense(comm, n, footprint):
    """H x by FFT equals the dense Eq. 10 product to 1e-12 relative.

    Both are sums of the same N terms; the FFT's round-off is O(ε log N) of
    the largest term, 1e-15 here, so 1e-12 leaves three orders of margin.
    """
    topo = topography(n, footprint)
    dense = Flexibility(topo, ROCK, comm, kind="dense")
    fft = Flexibility(topo, ROCK, comm, kind="fft")
    values = np.random.default_rng(n).standard_normal(dense.layout.size)
    x, y_dense = vectors(dense.mat, values)
    _, y_fft = vectors(fft.mat, values)
    dense.mat.mult(x, y_dense)
    fft.mat.mult(x, y_fft)
    a, b = gathered(comm, y_dense), gathered(comm, y_fft)
    assert np.linalg.norm(b - a) <= 1e-12 * np.linalg.norm(a)
    # and both equal the rows of Eq. 10 built node by node on one rank
    kernel = punch_kernel((n, n), SPACING, ROCK.compliance)
    rows = influence_rows(kernel, topo.footprint, slice(0, dense.layout.size))
    assert np.linalg.norm(rows @ values - a) <= 1e-12 * np.linalg.norm(a)
    for obj in (x, y_dense, y_fft):
        obj.destroy()
    dense.destroy()
    fft.destroy()


@pytest.mark.parametrize("footprint", ["square", "disc"])
def test_single_precision_product_and_preconditioner(comm, footprint):
    """The single-precision product and preconditioner (float32 FFTs) equal the double ones to
    1e-6 of the result, normwise and at every node: float32's ε = 6e-8 grows as O(ε log L) in an
    FFT (measured 2.6e-7 at 64², 4.5e-7 at 1025²). The result is float64 either way."""
    fft = Flexibility(topography(64, footprint), ROCK, comm, kind="fft")
    rng = np.random.default_rng(5)
    for values in (rng.standard_normal(fft.layout.local_size), rng.random(fft.layout.local_size)):
        nodes = np.flatnonzero(rng.random(values.size) < 0.4)
        for double, single in ((fft.product(values), fft.product(values, single=True)),
                               (fft.precondition_nodes(values[nodes], nodes),
                                fft.precondition_nodes(values[nodes], nodes, single=True))):
            assert single.dtype == np.float64
            error, size = (np.sqrt(comm.allreduce(float(v @ v))) for v in (single - double, double))
            assert error <= 1e-6 * size
            peak = comm.allreduce(float(np.abs(double).max(initial=0.0)), op=MPI.MAX)
            assert comm.allreduce(float(np.abs(single - double).max(initial=0.0)), op=MPI.MAX) <= 1e-6 * peak
    fft.destroy()


@pytest.mark.parametrize("kind", ["fft", "fft-periodic"])
@pytest.mark.parametrize("footprint", ["square", "disc"])
def test_product_of_a_sparse_field_equals_the_product_of_the_whole_field(comm, kind, footprint):
    """product_at (values written only at their nodes, the last call's nodes cleared) gives the
    same numbers as product of the field with zeros elsewhere, call after call on changing node
    sets and after a whole-field product that dirtied the buffer: both transform the same padded
    field, so they agree bit for bit (rtol 0, atol 0), in double and in single precision."""
    if kind == "fft-periodic" and footprint == "disc":
        pytest.skip("the periodic operator needs the whole grid")
    fft = Flexibility(topography(48, footprint), ROCK, comm, kind=kind)
    rng = np.random.default_rng(11)
    for single in (False, True):
        cases, sparse = [], []
        for density in (0.3, 0.02, 0.3, 0.0, 0.5, 0.1):
            if density == 0.5:
                fft.product(rng.standard_normal(fft.layout.local_size), single)    # a whole field
            nodes = np.flatnonzero(rng.random(fft.layout.local_size) < density)
            cases.append((nodes, rng.standard_normal(nodes.size)))
            sparse.append(fft.product_at(cases[-1][1], nodes, single))   # one after the other
        for (nodes, values), result in zip(cases, sparse):
            whole = np.zeros(fft.layout.local_size)
            whole[nodes] = values
            np.testing.assert_array_equal(result, fft.product(whole, single))
    fft.destroy()


@pytest.mark.parametrize("n", [47, 48])
@pytest.mark.parametrize("kind", ["fft", "fft-periodic"])
@pytest.mark.parametrize("footprint", ["square", "disc"])
def test_a_held_product_knows_its_energy_and_completes_to_the_product(comm, n, kind, footprint):
    """A product held between its transforms (held_product, held_product_at) reads xᵀHx off its
    spectrum by Parseval's theorem. It equals Σ x·(H x) summed on the nodes from the double
    product to 1e-12 in double (both O(ε log N) of the terms, all positive for the positive
    definite H). In single precision the spectrum is float32 (a product's error, 1e-6 of it,
    test_single_precision_product_and_preconditioner) and each block of SUMMED_ROWS rows is
    summed by a float32 dot, at most n · 2⁻²⁴ off for its n positive terms: the tolerance is
    their sum. A wrong weight of the columns ky = 0 or Ly / 2 would be off by about 1 / Ly. An
    odd period (47, fft-periodic) has no column ky = Ly / 2; an even one has. Completed, a held
    product is the product bit for bit: the same padded field through the same transforms. It
    cannot be completed twice, nor after another product overwrote its spectrum."""
    if kind == "fft-periodic" and footprint == "disc":
        pytest.skip("the periodic operator needs the whole grid")
    fft = Flexibility(topography(n, footprint), ROCK, comm, kind=kind)
    rng = np.random.default_rng(n)
    for single in (False, True):
        for density in (1.0, 0.3, 0.02):
            nodes = np.flatnonzero(rng.random(fft.layout.local_size) < density)
            values = rng.standard_normal(nodes.size)
            whole = np.zeros(fft.layout.local_size)
            whole[nodes] = values
            energy = comm.allreduce(float(whole @ fft.product(whole)))
            lengths = fft.convolution.lengths
            terms = passes.SUMMED_ROWS * 2 * (lengths[1] // 2 + 1)
            tolerance = 1e-6 + terms * 2.0 ** -24 if single else 1e-12
            held = fft.held_product_at(values, nodes, single)
            assert abs(comm.allreduce(held.energy) - energy) <= tolerance * energy
            np.testing.assert_array_equal(held.result(), fft.product_at(values, nodes, single))
            held = fft.held_product(whole, single)
            assert abs(comm.allreduce(held.energy) - energy) <= tolerance * energy
            np.testing.assert_array_equal(held.result(), fft.product(whole, single))
            with pytest.raises(RuntimeError, match="completed twice"):
                held.result()
            held = fft.held_product(whole, single)
            fft.product(whole, single)
            with pytest.raises(RuntimeError, match="overwrote its spectrum"):
                held.result()
    fft.destroy()


@pytest.mark.parametrize("footprint", ["square", "disc"])
def test_slab_positions_are_each_nodes_row_and_column_on_the_slab(comm, footprint):
    """layout.slab_positions(nodes) is (i − row_start) · ny + j for each node (i, j) of this rank
    given by local index, on whole rows (where it returns the indices themselves) and on a disc's
    footprint (where rows are partial); in the given order, repeated indices included."""
    fft = Flexibility(topography(37, footprint), ROCK, comm, kind="fft")
    layout = fft.layout
    grid = layout.local_nodes().astype(np.int64)
    expected = (grid[:, 0] - layout.rows[0]) * layout.shape[1] + grid[:, 1]
    rng = np.random.default_rng(2)
    for nodes in (np.arange(layout.local_size), np.flatnonzero(rng.random(layout.local_size) < 0.3),
                  rng.integers(0, max(layout.local_size, 1), 17), np.zeros(0, dtype=np.intp)):
        np.testing.assert_array_equal(layout.slab_positions(nodes), expected[nodes])
    assert comm.allreduce(layout.whole_rows, op=MPI.LAND) == (footprint == "square")
    fft.destroy()


@pytest.mark.parametrize("footprint", ["square", "disc"])
def test_index_sums_and_parities_are_those_of_each_nodes_indices(comm, footprint):
    """layout.index_sums() is (Σ i, Σ j) and layout.parities() is (i + j) mod 2 over this rank's
    nodes (i, j) as local_nodes() lists them, exactly (integers), on whole and partial rows of a
    37 × 37 grid (odd: the checkerboard's colours differ in count); summed over ranks, Σ i is the
    same on any number of ranks."""
    fft = Flexibility(topography(37, footprint), ROCK, comm, kind="fft")
    layout = fft.layout
    grid = layout.local_nodes().astype(np.int64)
    np.testing.assert_array_equal(layout.index_sums(), grid.sum(axis=0))
    np.testing.assert_array_equal(layout.parities(), (grid.sum(axis=1) % 2).astype(bool))
    mask = topography(37, footprint).footprint
    everywhere = np.argwhere(mask).sum(axis=0)
    np.testing.assert_array_equal(comm.allreduce(layout.index_sums()), everywhere)
    fft.destroy()


@pytest.mark.parametrize("kind", ["fft", "fft-periodic"])
def test_the_restricted_product_is_the_whole_product_at_the_nodes(comm, kind):
    """restricted (R_S K R_Sᵀ, read off the product before its crop) equals the whole field's
    product at the nodes bit for bit (rtol 0, atol 0), and product_at the whole product, for
    fields on both sides of convolution.DENSE_WRITE (more than one node in 8 is scattered
    through the columns buffer and read back through it, fewer at padded indices), one after
    the other in both orders, in single and double precision: either way the same padded field
    is transformed, and the dense write must leave no value of the last one behind."""
    from roughcontact.operators import convolution

    fft = Flexibility(topography(48, "square"), ROCK, comm, kind=kind)
    conv, layout = fft.convolution, fft.layout
    rng = np.random.default_rng(5)
    for single in (False, True):
        for density in (0.9, 0.02, 0.5, 1.0 / convolution.DENSE_WRITE + 0.03,
                        1.0 / convolution.DENSE_WRITE - 0.03, 0.0, 1.0, 0.3):
            nodes = np.flatnonzero(rng.random(layout.local_size) < density)
            values = rng.standard_normal(nodes.size)
            whole = np.zeros(layout.local_size)
            whole[nodes] = values
            expected = fft.product(whole, single)
            np.testing.assert_array_equal(fft.product_at(values, nodes, single), expected)
            read = conv.restricted(values, layout.positions[nodes], single)
            np.testing.assert_array_equal(read, expected[nodes].astype(read.dtype))
    fft.destroy()


@pytest.mark.parametrize("kind", ["fft", "fft-periodic"])
def test_a_transform_of_occupied_rows_only_equals_the_whole_one(comm, kind, monkeypatch):
    """product_at transforms along y only the runs of rows that hold values where that skips
    enough points (convolution.RUN_POINTS); forced on every sparse field (RUN_POINTS = 0) and
    forced off (no field qualifies), the products agree bit for bit (rtol 0, atol 0) with each
    other and with the whole field's product: the rows left out have zero spectra, and each
    row's transform is the same 1-D transform either way. Fields: blocks of rows, single rows,
    the first and last rows, nothing at all; single and double precision."""
    from roughcontact.operators import convolution

    n = 40
    fft = Flexibility(topography(n, "square"), ROCK, comm, kind=kind)
    rng = np.random.default_rng(3)
    local = fft.layout.local_nodes()[:, 0]                  # the grid row of each of this rank's nodes
    patterns = [np.isin(local, np.r_[3:9, 20:23]), np.isin(local, [0, n - 1]), local % 7 == 2,
                np.zeros(local.size, dtype=bool), np.isin(local, np.r_[10:30])]
    for single in (False, True):
        for rows in patterns:
            nodes = np.flatnonzero(rows & (rng.random(local.size) < 0.5))
            values = rng.standard_normal(nodes.size)
            products = []
            for points in (0, 10**12):
                monkeypatch.setattr(convolution, "RUN_POINTS", points)
                products.append(fft.product_at(values, nodes, single))
            whole = np.zeros(fft.layout.local_size)
            whole[nodes] = values
            np.testing.assert_array_equal(products[0], products[1])
            np.testing.assert_array_equal(products[0], fft.product(whole, single))
    fft.destroy()


@pytest.mark.parametrize("kind", ["fft", "fft-periodic"])
def test_products_of_both_precisions_share_one_buffer(comm, kind):
    """Single and double products share one padded storage (the single buffers are the first
    half of the double ones' bytes): in any order of precisions, of whole and of sparse fields,
    each product equals bit for bit (rtol 0, atol 0) the one of an operator that only ever takes
    products of that precision, which transforms the same padded field; and the buffers do share
    their memory."""
    topo = topography(48, "square")
    mixed = Flexibility(topo, ROCK, comm, kind=kind)
    alone = {single: Flexibility(topo, ROCK, comm, kind=kind) for single in (False, True)}
    rng = np.random.default_rng(5)
    size = mixed.layout.local_size
    for single, density in [(True, 0.3), (False, 0.02), (True, 0.05), (True, 1.0), (False, 0.3),
                            (True, 0.0), (False, 1.0), (True, 0.2), (False, 0.1)]:
        if density == 1.0:
            field = rng.standard_normal(size)
            np.testing.assert_array_equal(mixed.product(field, single), alone[single].product(field, single))
            continue
        nodes = np.flatnonzero(rng.random(size) < density)
        values = rng.standard_normal(nodes.size)
        np.testing.assert_array_equal(mixed.product_at(values, nodes, single),
                                      alone[single].product_at(values, nodes, single))
    buffers = mixed.convolution._buffers
    assert all(np.shares_memory(buffers[True][k], buffers[False][k]) for k in (0, 1))
    for operator in (mixed, *alone.values()):
        operator.destroy()


def test_diagonal_is_the_punch_self_term(comm):
    """getDiagonal = A/(4a) = A/(2s) (Eq. 10 at r = 0) on every node."""
    fft = Flexibility(topography(16, "disc"), ROCK, comm, kind="fft")
    diagonal = fft.mat.getDiagonal()
    np.testing.assert_allclose(diagonal.getArray(), ROCK.compliance / (2 * SPACING), rtol=1e-15)
    diagonal.destroy()
    fft.destroy()


@pytest.mark.parametrize("kind", ["table", "formula", "matrix-free", "matrix-free single"])
def test_contact_set_block_equals_dense_submatrix(comm, kind, monkeypatch):
    """H_SS (explicit, read from the Eq. 10 table or evaluated entry by entry from Eq. 10, or
    matrix-free) equals the dense sub-matrix product to 1e-12 (1e-6 with single-precision products,
    whose float32 round-off is about 1e-7); only the reads from the table keep it."""
    from roughcontact.operators import flexibility

    if kind == "formula":
        monkeypatch.setattr(flexibility, "TABLE_BYTES", 0)
    explicit = not kind.startswith("matrix-free")
    topo = topography(24, "disc")
    dense = Flexibility(topo, ROCK, comm, kind="dense")
    fft = Flexibility(topo, ROCK, comm, kind="fft")
    rng = np.random.default_rng(7)
    active_all = rng.random(dense.layout.size) < 0.3
    active = active_all[dense.layout.start:dense.layout.stop]
    reference = dense.block(active)
    block = fft.block(active, explicit=explicit, single=kind.endswith("single"))
    assert (block.getType() == PETSc.Mat.Type.PYTHON) is not explicit
    if not explicit:
        assert block.getPythonContext().single == kind.endswith("single")
    assert (fft._table is not None) == (kind == "table")
    values = rng.standard_normal(int(active_all.sum()))
    x, y = reference.createVecs()
    start, stop = reference.getOwnershipRange()
    x.getArray()[:] = values[start:stop]
    reference.mult(x, y)
    expected = gathered(comm, y)
    block.mult(x, y)
    bound = 1e-6 if kind.endswith("single") else 1e-12
    assert np.linalg.norm(gathered(comm, y) - expected) <= bound * np.linalg.norm(expected)
    for obj in (x, y, reference, block):
        obj.destroy()
    dense.destroy()
    fft.destroy()


def test_blocks_from_the_formula_are_the_tables_entries_bit_for_bit():
    """Eq. 10 evaluated at each entry's offsets (punch_block) gives the entries of the table
    K[|Δi|, |Δj|] (punch_kernel) bit for bit, as do the reads from the table (kernel_block), on a
    grid that is not square and in chunks of any size; and the formula's block allocates nothing
    of the grid's size: at most 8 times the block's bytes (the block and its chunk's temporaries:
    offsets, distances, ratios), traced, for 200 nodes of a 2048 × 2047 grid, whose Eq. 10 table
    alone would take 33 MB."""
    from roughcontact.operators.kernel import punch_block

    shape, spacing = (37, 23), 2.5e-4
    rng = np.random.default_rng(3)
    rows = np.stack(np.unravel_index(rng.choice(shape[0] * shape[1], 60, replace=False), shape), axis=1)
    columns = np.stack(np.unravel_index(rng.choice(shape[0] * shape[1], 45, replace=False), shape), axis=1)
    table = punch_kernel(shape, spacing, ROCK.compliance)
    expected = table_block(table, rows, columns)
    for chunk in (1, 7, 1 << 18):
        np.testing.assert_array_equal(punch_block(spacing, ROCK.compliance, rows, columns, chunk=chunk), expected)
        np.testing.assert_array_equal(kernel_block(table, shape, rows, columns, chunk=chunk), expected)
    large = (2048, 2047)
    nodes = np.stack(np.unravel_index(rng.choice(large[0] * large[1], 200, replace=False), large), axis=1)
    peak = traced_peak(punch_block, spacing, ROCK.compliance, nodes, nodes)
    assert peak <= 8 * 8 * 200 ** 2, peak


def test_createsubmatrix_of_the_matrix_free_operator(comm):
    """PETSc's createSubMatrix on the FFT Mat returns H_SS (same product as the dense one)."""
    topo = topography(20, "square")
    dense = Flexibility(topo, ROCK, comm, kind="dense")
    fft = Flexibility(topo, ROCK, comm, kind="fft")
    start, stop = fft.layout.start, fft.layout.stop
    rows = np.arange(start, stop)[::3].astype(PETSc.IntType)
    index_set = PETSc.IS().createGeneral(rows, comm=comm)
    subs = [op.mat.createSubMatrix(index_set, index_set) for op in (dense, fft)]
    x, y = subs[0].createVecs()
    x.getArray()[:] = np.linspace(-1.0, 2.0, x.getLocalSize())
    out = []
    for sub in subs:
        sub.mult(x, y)
        out.append(gathered(comm, y))
    assert np.linalg.norm(out[1] - out[0]) <= 1e-12 * np.linalg.norm(out[0])
    for obj in (*subs, x, y, index_set):
        obj.destroy()
    dense.destroy()
    fft.destroy()


@pytest.mark.parametrize("n", [32, 33])
def test_fourier_preconditioner_is_symmetric_positive_definite(comm, n):
    """z = R_S C⁻¹ R_Sᵀ g is symmetric and positive on S (so it can precondition CG):
    xᵀ M y = yᵀ M x to round-off, and xᵀ M x > 0 for random x. C's period is 48 along x at 32²
    and 49 (odd: its middle row of kx has no mirror) at 33²."""
    fft = Flexibility(topography(n, "disc"), ROCK, comm, kind="fft")
    rng = np.random.default_rng(3)
    n = fft.layout.local_size
    active = rng.random(n) < 0.4
    nodes = np.flatnonzero(active)
    x, y = rng.standard_normal(nodes.size), rng.standard_normal(nodes.size)
    mx, my = fft.precondition_nodes(x, nodes), fft.precondition_nodes(y, nodes)
    xmy, ymx, xmx = (comm.allreduce(float(v)) for v in (x @ my, y @ mx, x @ mx))
    assert abs(xmy - ymx) <= 1e-12 * abs(xmx)
    assert xmx > 0.0
    fft.destroy()


def assert_product_is_the_sum(convolution, table, field, di, dj):
    """convolution.apply(field) on this rank's rows equals u_a = Σ_c table[di(a, c), dj(a, c)] x_c
    written out term by term (di, dj: the table's row and column for each pair of grid rows and of
    grid columns), to 1e-12 of the largest value in double and 1e-6 in single."""
    direct = np.einsum("abcd,cd->ab", table[di[:, None, :, None], dj[None, :, None, :]], field)
    r0, r1 = convolution.rows
    scale = np.abs(direct).max()
    for single, tolerance in ((False, 1e-12), (True, 1e-6)):
        product = convolution.apply(np.ascontiguousarray(field[r0:r1]), single)
        assert np.abs(product - direct[r0:r1]).max(initial=0.0) <= tolerance * scale, single


@pytest.mark.parametrize("period", [(45, 45), (44, 45), (48, 48), (57, 50)])
def test_a_product_on_a_longer_period_is_the_folded_sum_written_out(comm, period):
    """A convolution keeps its symbol's rows kx = 0 … Lx // 2 and scales the others by their
    mirror, the symbol of an even kernel being even in kx. On periods odd and even along x (both
    even: the symbol from cosine transforms of the table) the product equals the circular sum
    u_a = Σ_c k(fold(a − c)) x_c over the period, written out term by term (fold(d) =
    min(d mod L, L − d mod L) per direction; a random table, so no symmetry of the kernel's values
    hides a wrong row): to 1e-12 of the largest value in double
    (the FFT's round-off is O(ε log L), about 1e-15) and 1e-6 in single (float32's ε = 6e-8 grown
    as O(ε log L), as above)."""
    from roughcontact.operators.convolution import SlabConvolution

    n = 29
    convolution = SlabConvolution((n, n), comm, period=period)
    rng = np.random.default_rng(sum(period))
    table = rng.random((n, n))
    field = rng.standard_normal((n, n))                # the same on every rank
    convolution.set_folded_kernel(table)
    offsets = np.arange(n)[:, None] - np.arange(n)[None, :]
    fx, fy = (np.minimum(offsets % length, -offsets % length) for length in period)
    assert_product_is_the_sum(convolution, table, field, fx, fy)


@pytest.mark.parametrize("shape", [(24, 40), (37, 23), (24, 21), (23, 24)])
def test_a_linear_product_is_the_sum_over_signed_offsets_written_out(comm, shape):
    """The non-periodic product u_a = Σ_c k(|a − c|) x_c over the grid, written out term by term,
    for a random even table (no symmetry of Eq. 10's values hides a wrong row). The shapes give
    padded lengths (Lx, Ly) (48, 80), (75, 45), (48, 45) and (45, 48): both even, where the
    symbol comes from type-I cosine transforms of the table, and odd in either direction or both,
    where it comes from the extended table's transform. To 1e-12 of the largest value in double
    (the FFT's round-off, O(ε log L), is about 1e-15) and 1e-6 in single (float32's ε)."""
    from roughcontact.operators.convolution import SlabConvolution

    convolution = SlabConvolution(shape, comm)
    assert [length % 2 for length in convolution.lengths] == {
        (24, 40): [0, 0], (37, 23): [1, 1], (24, 21): [0, 1], (23, 24): [1, 0]}[shape]
    rng = np.random.default_rng(shape[0] * 100 + shape[1])
    table = rng.random(shape)
    field = rng.standard_normal(shape)                 # the same on every rank
    convolution.set_kernel(table)
    dx, dy = (np.abs(np.arange(n)[:, None] - np.arange(n)[None, :]) for n in shape)
    assert_product_is_the_sum(convolution, table, field, dx, dy)


def test_a_symbol_that_is_not_even_is_refused(comm):
    """Only the rows kx ≤ Lx // 2 of a symbol are kept, so a symbol whose row Lx − k is not row k
    (not the symbol of an even kernel) is refused in one line instead of being replaced by the
    mirror of its first half."""
    from roughcontact.operators.convolution import SlabConvolution

    convolution = SlabConvolution((16, 16), comm)
    c0, c1 = convolution.my_columns
    symbol = np.ones((convolution.lengths[0], c1 - c0))
    symbol[1] = 2.0                                    # row Lx − 1 stays 1
    with pytest.raises(ValueError, match="not even in kx"):
        convolution.set_symbol(symbol)
    symbol[-1] = 2.0                                   # now even: kept, and given back whole
    convolution.set_symbol(symbol)
    assert np.array_equal(convolution.symbol, symbol)


def test_ewald_sum_is_independent_of_the_splitting():
    """The lattice sum of 1/r does not depend on the Ewald parameter α (to round-off, 1e-15
    of its largest value), and matches a direct image sum: differences between two offsets
    summed over a square of images |m| ≤ M of a square cell converge like c1/M + c2/M²,
    so Richardson's extrapolation from M = 200, 400, 800 is exact to 1e-8 relative
    (measured 1.6e-9; a single step on 200, 400 leaves 2e-6)."""
    a, b = lattice_coulomb((16, 20), 1.0, 1.5), lattice_coulomb((16, 20), 1.0, 3.0)
    assert np.abs(a - b).max() <= 1e-14 * np.abs(b).max()
    lx = ly = 16
    b = lattice_coulomb((lx, ly), 1.0)

    def direct(images):
        m = np.arange(-images, images + 1)
        mx, my = np.meshgrid(m, m, indexing="ij")
        total = lambda p: (1.0 / np.hypot(p[0] + lx * mx, p[1] + ly * my)).sum()   # noqa: E731
        return total((3.0, 5.0)) - total((7.0, 1.0))

    extrapolated = (8.0 * direct(800) - 6.0 * direct(400) + direct(200)) / 3.0
    assert b[3, 5] - b[7, 1] == pytest.approx(extrapolated, rel=1e-8)


def test_periodic_operator_is_the_image_sum_of_eq10(comm):
    """A load on a small patch in a large periodic cell displaces its neighbourhood as the
    non-periodic operator does, up to a constant (the gauge) and the images' field, whose
    variation over the region, A P r/(2π L²)·O(1), is below 1 % of the local displacement."""
    n = 128
    topo = Topography(np.zeros((n, n)), SPACING)
    periodic = Flexibility(topo, ROCK, comm, kind="fft-periodic")
    plain = Flexibility(topo, ROCK, comm, kind="fft")
    field = np.zeros((n, n))
    field[60:68, 60:68] = 1.0
    values = field.ravel()
    local = slice(periodic.layout.start, periodic.layout.stop)
    u_per = np.concatenate(comm.allgather(periodic.product(values[local]))).reshape(n, n)
    u_np = np.concatenate(comm.allgather(plain.product(values[local]))).reshape(n, n)
    near = (slice(52, 76), slice(52, 76))
    difference = (u_per - u_np)[near]
    assert np.ptp(difference) <= 0.01 * u_np[near].max()
    # gauge: the periodic kernel has zero mean over the cell, so the displacement does too
    assert abs(u_per.mean()) <= 1e-12 * np.abs(u_per).max()
    # the image sum is symmetric: explicit blocks read the table modulo the period
    nodes = np.array([[0, 0], [0, n - 1], [n - 1, 3]])
    block = kernel_block(periodic.table, (n, n), nodes, nodes, periodic=True)
    np.testing.assert_allclose(block, block.T, rtol=1e-15)
    assert block[0, 1] == periodic.table[0, 1]          # offset −1 ≡ 1 (mod n)
    periodic.destroy()
    plain.destroy()


def test_periodic_kernel_self_term_and_symmetry():
    """k_per is even (k[i] = k[n − i]) and its self term exceeds every other entry."""
    table = periodic_kernel((32, 32), SPACING, ROCK.compliance)
    np.testing.assert_allclose(table[1:, :], table[:0:-1, :], rtol=1e-12)
    np.testing.assert_allclose(table[:, 1:], table[:, :0:-1], rtol=1e-12)
    assert table[0, 0] == table.max()
    assert abs(table.mean()) <= 1e-15 * table[0, 0]


def test_operator_on_three_ranks(tmp_path, comm):
    """The FFT product equals the dense one on 3 ranks (a row split that leaves ranks
    unequal rows and frequency columns), 1e-12 relative as above."""
    if comm.Get_size() > 1:
        pytest.skip("spawns mpiexec; run by the serial pass")
    script = tmp_path / "three.py"
    script.write_text(
        "import numpy as np\n"
        "from mpi4py import MPI\n"
        "from roughcontact.materials import Interface, Material\n"
        "from roughcontact.operators.flexibility import Flexibility\n"
        "from roughcontact.surfaces import Topography, disc\n"
        "comm = MPI.COMM_WORLD\n"
        "topo = Topography(np.zeros((31, 29)), 1e-4, disc((31, 29), 1e-4, 2.6e-3))\n"
        "iface = Interface(Material(20e9, 0.2))\n"
        "ops = [Flexibility(topo, iface, comm, kind=k) for k in ('dense', 'fft')]\n"
        "values = np.random.default_rng(0).standard_normal(ops[0].layout.size)\n"
        "out = []\n"
        "for op in ops:\n"
        "    x, y = op.mat.createVecs()\n"
        "    x.getArray()[:] = values[op.layout.start:op.layout.stop]\n"
        "    op.mat.mult(x, y)\n"
        "    out.append(np.concatenate(comm.allgather(y.getArray().copy())))\n"
        "err = np.linalg.norm(out[1] - out[0]) / np.linalg.norm(out[0])\n"
        "assert err <= 1e-12, err\n"
        "if comm.rank == 0: print('ok', err)\n")
    launcher = str(__import__("pathlib").Path(sys.executable).parent / "mpiexec")
    run = subprocess.run([launcher, "-n", "3", sys.executable, str(script)], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("ok")
