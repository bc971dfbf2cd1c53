"""Passes over a rank's large arrays shared by its FFT threads.

A product's transforms use ``workers`` threads (:mod:`.convolution`), but the
passes between them ran on one: the product with the symbol, the zeroing of
the padded rows, the copies into and out of the padded buffers. These are
large memory-bound loops (a 4096² padded spectrum in single precision is
134 MB), and numpy releases the GIL inside each, so the same threads can
share them by contiguous blocks of rows. Two threads against one on this
project's 2-core machines (medians of 9): the product with the symbol of a
4096² padded spectrum 35.9 → 20.6 ms, zeroing its lower half 16.9 → 9.2 ms.

The pool is made on first use and kept for the process; with one worker the
work runs in the calling thread.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

#: rows of a pass below which it runs in the calling thread (a share's hand-over costs ~20 µs)
SHARED_FROM = 64

_pool: ThreadPoolExecutor | None = None


def _executor(threads: int) -> ThreadPoolExecutor:
    """The process's pool, with at least ``threads`` threads."""
    global _pool
    if _pool is None or _pool._max_workers < threads:
        if _pool is not None:
            _pool.shutdown(wait=True)
        _pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="roughcontact-pass")
    return _pool


def by_rows(workers: int, count: int, work) -> None:
    """``work(start, stop)`` over ``workers`` contiguous shares of ``range(count)``, one of them in
    the calling thread; returns when every share is done (the first error is raised)."""
    if workers <= 1 or count < SHARED_FROM:
        work(0, count)
        return
    bounds = np.linspace(0, count, workers + 1).astype(int)
    futures = [_executor(workers - 1).submit(work, int(a), int(b)) for a, b in zip(bounds[1:-1], bounds[2:])]
    try:
        work(int(bounds[0]), int(bounds[1]))
    finally:
        for future in futures:
            future.result()


def fill(target: np.ndarray, value: float, workers: int) -> None:
    """target[...] = value, by blocks of its leading axis."""
    by_rows(workers, target.shape[0], lambda a, b: target[a:b].fill(value))


def copy(target: np.ndarray, source: np.ndarray, workers: int) -> None:
    """target[...] = source (same leading length; casts as numpy's assignment does)."""
    by_rows(workers, target.shape[0], lambda a, b: np.copyto(target[a:b], source[a:b], casting="unsafe"))


def scale(target: np.ndarray, factor: np.ndarray, workers: int) -> None:
    """target *= factor (same leading length), in place."""
    by_rows(workers, target.shape[0], lambda a, b: np.multiply(target[a:b], factor[a:b], out=target[a:b]))
