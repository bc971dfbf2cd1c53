"""The product's passes shared by threads (roughcontact/operators/passes.py): every row exactly
once, the numbers numpy gives, and products that do not depend on the thread count.

The threads split elementwise loops by rows and pocketfft splits its batches of 1-D transforms
by lines; neither changes an operation's order within an element or a line, so the products
must agree bit for bit. Run serially and under ``mpiexec -n 2`` (each rank its own threads).
"""
from __future__ import annotations

import threading

import numpy as np
import pytest

from roughcontact.operators import convolution, passes
from roughcontact.operators.convolution import SlabConvolution
from roughcontact.operators.kernel import punch_kernel


@pytest.fixture
def shared_always(monkeypatch):
    """Every pass split, however small its array (the tests' grids are far below SHARED_VALUES)."""
    monkeypatch.setattr(passes, "SHARED_VALUES", 1)


@pytest.mark.parametrize("count", [0, 1, 2, 3, 1001])
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_every_row_once(count, workers):
    seen = np.zeros(count, dtype=int)
    shares = []

    def work(start, stop):
        shares.append((start, stop))
        np.add.at(seen, np.arange(start, stop), 1)

    passes.by_rows(workers, count, work)
    assert np.all(seen == 1)
    assert len(shares) == max(1, min(workers, count))


def test_an_error_is_raised_only_after_every_share_ends():
    """With three shares the second fails at once while the third is still running: the call must
    not return (nor raise) before the third has ended, nor hide the calling thread's own error.
    The third share waits up to 1 s for the test to have seen the call end; it must not see it."""
    returned, seen = threading.Event(), []

    def work(start, stop):
        if start == 0:
            return
        if stop < 300:
            raise ValueError("second share failed")
        seen.append(returned.wait(1.0))                   # True only if the call ended before this share

    try:
        with pytest.raises(ValueError, match="second share failed"):
            passes.by_rows(3, 300, work)
    finally:
        returned.set()
    assert seen == [False]

    def first_fails(start, stop):
        raise KeyError("calling thread") if start == 0 else ValueError("pool thread")

    with pytest.raises(KeyError, match="calling thread"):
        passes.by_rows(2, 10, first_fails)


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.complex64])
def test_fill_copy_scale_equal_numpy(shared_always, dtype):
    """On reversed rows too (the symbol's mirror is a view with its rows reversed), and a
    broadcast operand left to numpy whole."""
    rng = np.random.default_rng(5)
    source = rng.standard_normal((300, 70)).astype(dtype)
    factor = rng.standard_normal((300, 70)).astype(np.float32 if dtype == np.complex64 else dtype)
    if dtype != np.complex64:
        target = np.empty((300, 70))                     # cast on the way, as the nodal copy does
        passes.copy(target, source[::-1], 2)
        assert np.array_equal(target, source[::-1].astype(np.float64))
        passes.copy(target, source[:1], 2)
        assert np.array_equal(target, np.broadcast_to(source[:1], target.shape).astype(np.float64))
    scaled = source.copy()
    passes.scale(scaled, factor[::-1], 2)
    assert np.array_equal(scaled, source * factor[::-1])
    passes.scale(scaled, factor[0], 2)
    assert np.array_equal(scaled, source * factor[::-1] * factor[0])
    passes.fill(scaled, 0.0, 2)
    assert not scaled.any()


def _products(conv: SlabConvolution, n: int, single: bool) -> list[np.ndarray]:
    """Every write path of a product: a whole field, values at a few nodes (the runs of their
    rows alone transformed: the rows of the slab's first and last 10, gaps of 64 rows and more),
    at most nodes (the dense write), and the restricted products of both; and held products,
    their energies (read off the spectrum) and one completed."""
    rng = np.random.default_rng(11)
    r0, r1 = conv.rows
    count = r1 - r0
    rows = np.r_[0:10, count - 10:count]
    sparse = (rows[:, None] * n + rng.choice(n, 5, replace=False)[None, :]).ravel()
    dense = np.sort(rng.choice(count * n, count * n * 3 // 4, replace=False))
    field = rng.standard_normal((count, n))
    held = conv.held(field, single)
    held_at = conv.held_at(rng.standard_normal(dense.size), dense, single)
    return [np.array(held_at.energy), np.array(held_at.result()), np.array(held.energy),
            np.array(conv.apply(field, single)),
            np.array(conv.apply_at(rng.standard_normal(sparse.size), sparse, single)),
            np.array(conv.apply_at(rng.standard_normal(dense.size), dense, single)),
            np.array(conv.restricted(rng.standard_normal(dense.size), dense, single)),
            np.array(conv.restricted(rng.standard_normal(sparse.size), sparse, single))]


@pytest.mark.parametrize("single", [False, True])
@pytest.mark.parametrize("period", [None, (260, 260)])
def test_products_do_not_depend_on_the_threads(comm, shared_always, monkeypatch, single, period):
    """The half-space product and a periodic one on a longer period, every write path, in both
    precisions, and a held product's energy: equal bit for bit with one thread and with two,
    every pass split (the run gaps too: RUN_POINTS 0 transforms only the occupied runs of rows)."""
    monkeypatch.setattr(convolution, "RUN_POINTS", 0)
    n = 100 * comm.Get_size() if comm.Get_size() > 1 else 150
    table = punch_kernel((n, n), 1e-4, 1e-11)
    results = []
    for workers in (1, 2):
        conv = SlabConvolution((n, n), comm, workers=workers, period=period)
        (conv.set_folded_kernel if period else conv.set_kernel)(table)
        results.append(_products(conv, n, single))
    for one, two in zip(*results):
        assert one.dtype == two.dtype
        assert np.array_equal(one, two)


@pytest.mark.parametrize("dtype", [np.float32, np.complex64, np.complex128])
@pytest.mark.parametrize("rows", [0, 1, 17, 300])
def test_scale_summed_scales_as_numpy_and_sums_the_scaled_squares(shared_always, dtype, rows):
    """scale_summed multiplies as numpy does, bit for bit, on reversed rows of the factor too (the
    symbol's mirror); its sum Σ t·(f t) over the real view is the same bits with one thread and
    two (the threads split whole blocks), and the float64 sum to the bound of a dot of positive
    terms: each block of SUMMED_ROWS rows is summed in its own precision, n terms with a relative
    error of at most n · u (u = 2⁻²⁴ in single, 2⁻⁵³ in double), and one u more for the rounding
    of the scaled values."""
    rng = np.random.default_rng(rows)
    real = np.float64 if dtype == np.complex128 else np.float32
    source = rng.standard_normal((rows, 70)).astype(real)
    if dtype != np.float32:
        source = (source + 1j * rng.standard_normal((rows, 70))).astype(dtype)
    factor = (0.5 + rng.random((rows, 70))).astype(real)[::-1]   # positive, as a symbol's values
    view = source.view(real)
    terms = view.shape[1] * passes.SUMMED_ROWS
    expected = float(np.sum(view.astype(np.float64) ** 2 * np.repeat(factor, view.shape[1] // 70, axis=1)))
    totals = []
    for workers in (1, 2):
        target = source.copy()
        totals.append(passes.scale_summed(target, factor, workers))
        assert np.array_equal(target, source * factor)
        assert abs(totals[-1] - expected) <= (terms + 1) * np.finfo(real).eps / 2 * expected
    assert totals[0] == totals[1]


def test_scale_summed_takes_no_broadcast_factor():
    """A factor of one row would be sliced by the target's rows: refused, not broadcast wrongly."""
    with pytest.raises(ValueError, match="factor of the target's rows"):
        passes.scale_summed(np.ones((40, 8), np.float32), np.ones((1, 8), np.float32), 2)


@pytest.mark.parametrize("workers", [1, 2, 3])
@pytest.mark.parametrize("share", [0.0, 0.01, 0.86, 1.0])
def test_node_passes_equal_numpy(shared_always, workers, share):
    """The constrained CG's passes over a rank's nodes (roughcontact/normal/constrained_cg.py):
    the indices of a mask, gathers and scatters at them, and elementwise ufuncs, against numpy's
    own calls bit for bit, on masks from empty to full and a length that no share count divides."""
    rng = np.random.default_rng(int(share * 100) + workers)
    size = 1009
    mask = rng.random(size) < share
    nodes = passes.nonzero(mask, workers)
    assert nodes.dtype == np.intp
    assert np.array_equal(nodes, np.flatnonzero(mask))
    for dtype in (np.float64, np.float32):
        values = rng.standard_normal(size).astype(dtype)
        assert np.array_equal(passes.gather(values, nodes, workers), values[nodes])
        out = np.full(nodes.size, np.nan, dtype=dtype)
        assert passes.gather(values, nodes, workers, out=out) is out
        assert np.array_equal(out, values[nodes])
        written, expected = values.copy(), values.copy()
        new = rng.standard_normal(nodes.size).astype(dtype)
        passes.scatter(written, nodes, new, workers)
        expected[nodes] = new
        assert np.array_equal(written, expected)
        passes.scatter(written, nodes, 0.0, workers)
        expected[nodes] = 0.0
        assert np.array_equal(written, expected)
    first, second = rng.standard_normal(size), rng.standard_normal(size)
    for ufunc, dtype in ((np.add, float), (np.subtract, float), (np.multiply, float), (np.less, bool)):
        out = np.empty(size, dtype=dtype)
        assert np.array_equal(passes.combine(ufunc, first, second, out, workers), ufunc(first, second))
        assert np.array_equal(passes.combine(ufunc, first, 0.25, out, workers), ufunc(first, 0.25))
        assert np.array_equal(passes.combine(ufunc, first[:1], second, out, workers), ufunc(first[:1], second))
    flags = rng.random(size) < 0.5
    in_place = flags.copy()
    passes.combine(np.greater, in_place, mask, in_place, workers)          # the output an input
    assert np.array_equal(in_place, flags > mask)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_largest_magnitude_equals_numpys(dtype):
    """max |x| by the largest and smallest values, exactly numpy's np.abs(x).max(initial=0) (a
    negation is exact): values of both signs, one sign, none, and a NaN, which it passes on."""
    rng = np.random.default_rng(5)
    for values in (rng.standard_normal(1009), -rng.random(64), rng.random(64), np.zeros(0)):
        values = values.astype(dtype)
        assert passes.largest_magnitude(values) == float(np.abs(values).max(initial=0.0))
    with_nan = rng.standard_normal(16).astype(dtype)
    with_nan[7] = np.nan
    assert np.isnan(passes.largest_magnitude(with_nan))


@pytest.mark.parametrize("scene", ["sparse", "full"])
def test_a_constrained_cg_solve_does_not_depend_on_the_threads(comm, shared_always, scene):
    """A whole nested CG solve (its loop's passes over the nodes and its products, every one split
    between threads) gives the same forces, bit for bit, and the same iterations with one thread
    and with two: elementwise passes and gathers split by nodes change no operation's order."""
    from roughcontact.materials import Interface, Material
    from roughcontact.normal import NormalProblem, make_solver
    from roughcontact.surfaces import Topography, fourier_surface

    n = 160
    shape = {"fractal_dimension": 2.5} if scene == "full" else {"hurst": 0.8}
    heights = fourier_surface(n, 1.0 / n, rms_slope=1.0, rolloff_wavelength=1.0,
                              short_cutoff_wavelength=8.0 / n, periodic=False, seed=3, **shape).heights
    pressure = 1.0 if scene == "full" else 0.01
    results = []
    for workers in (1, 2):
        problem = NormalProblem(Topography(np.asarray(heights), 1.0 / n), Interface(Material(1.0, 0.0)), comm,
                                operator="fft", workers=workers)
        with make_solver(problem, "cg") as solver:
            result = solver.solve_load(pressure, rotation=(0.0, 0.0))
        results.append(result)
    assert results[0].linear_iterations == results[1].linear_iterations
    assert results[0].coarse_iterations == results[1].coarse_iterations
    assert np.array_equal(results[0].pressure, results[1].pressure)
    assert 0.05 < results[0].contact_fraction < 0.99 if scene == "full" else results[0].contact_fraction < 0.2
