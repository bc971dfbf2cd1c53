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
