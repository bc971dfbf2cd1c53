"""The product's passes shared by threads (roughcontact/operators/passes.py): every row exactly
once, the numbers numpy gives, and products that do not depend on the thread count.

The threads split elementwise loops by rows and pocketfft splits its batches of 1-D transforms
by lines; neither changes an operation's order within an element or a line, so the products
must agree bit for bit. Run serially and under ``mpiexec -n 2`` (each rank its own threads).
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.operators import passes
from roughcontact.operators.convolution import SlabConvolution
from roughcontact.operators.kernel import punch_kernel


@pytest.mark.parametrize("count", [0, 1, passes.SHARED_FROM - 1, passes.SHARED_FROM, 1001])
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_every_row_once(count, workers):
    seen = np.zeros(count, dtype=int)
    shares = []

    def work(start, stop):
        shares.append((start, stop))
        np.add.at(seen, np.arange(start, stop), 1)

    passes.by_rows(workers, count, work)
    assert np.all(seen == 1)
    expected = 1 if workers == 1 or count < passes.SHARED_FROM else workers
    assert len(shares) == expected


def test_an_error_in_a_share_is_raised_after_every_share_ends():
    ended = []

    def work(start, stop):
        if start > 0:
            raise ValueError("share failed")
        ended.append((start, stop))

    with pytest.raises(ValueError, match="share failed"):
        passes.by_rows(2, 200, work)
    assert ended == [(0, 100)]


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.complex64])
def test_fill_copy_scale_equal_numpy(dtype):
    """On reversed rows too (the symbol's mirror is a view with its rows reversed)."""
    rng = np.random.default_rng(5)
    source = rng.standard_normal((300, 70)).astype(dtype)
    factor = rng.standard_normal((300, 70)).astype(np.float32 if dtype == np.complex64 else dtype)
    if dtype != np.complex64:
        target = np.empty((300, 70))                     # cast on the way, as the nodal copy does
        passes.copy(target, source[::-1], 2)
        assert np.array_equal(target, source[::-1].astype(np.float64))
    scaled = source.copy()
    passes.scale(scaled, factor[::-1], 2)
    assert np.array_equal(scaled, source * factor[::-1])
    passes.fill(scaled, 0.0, 2)
    assert not scaled.any()


def _products(conv: SlabConvolution, n: int, single: bool) -> list[np.ndarray]:
    rng = np.random.default_rng(11)
    r0, r1 = conv.rows
    slab = (r1 - r0) * n
    sparse = np.sort(rng.choice(slab, slab // 50 + 1, replace=False)) if slab else np.zeros(0, int)
    dense = np.sort(rng.choice(slab, slab * 3 // 4, replace=False)) if slab else np.zeros(0, int)
    field = rng.standard_normal((r1 - r0, n))
    return [np.array(conv.apply(field, single)),
            np.array(conv.apply_at(rng.standard_normal(sparse.size), sparse, single)),
            np.array(conv.apply_at(rng.standard_normal(dense.size), dense, single)),
            np.array(conv.restricted(rng.standard_normal(dense.size), dense, single)),
            np.array(conv.restricted(rng.standard_normal(sparse.size), sparse, single))]


@pytest.mark.parametrize("single", [False, True])
@pytest.mark.parametrize("period", [None, (150, 150)])
def test_products_do_not_depend_on_the_threads(comm, single, period):
    """The half-space product and a periodic one on a longer period, every write path, in both
    precisions: equal bit for bit with one thread and with two (rows ≥ SHARED_FROM per rank, so
    the passes are split)."""
    n = 2 * passes.SHARED_FROM + 8 if comm.Get_size() > 1 else passes.SHARED_FROM + 16
    table = punch_kernel((n, n), 1e-4, 1e-11)
    results = []
    for workers in (1, 2):
        conv = SlabConvolution((n, n), comm, workers=workers, period=period)
        (conv.set_folded_kernel if period else conv.set_kernel)(table)
        results.append(_products(conv, n, single))
    for one, two in zip(*results):
        assert one.dtype == two.dtype
        assert np.array_equal(one, two)
