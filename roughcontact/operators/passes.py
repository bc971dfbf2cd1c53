"""Passes over a rank's large arrays shared by its FFT threads.

A product's transforms use ``workers`` threads (:mod:`.convolution`), but the
passes between them ran on one: the product with the symbol, the zeroing of
the padded buffers, the copies into and out of them. These are large
memory-bound loops (the padded spectrum of a 4096² grid in single precision
is 268 MB), and numpy releases the GIL inside each, so the same threads can
share them by contiguous blocks of rows (docs/solver-cost.md, "The passes
between the transforms", gives what it saves). The constrained CG's passes
over a rank's nodes (the gap, the sets' masks and indices, the gathers and
scatters of the free set: :func:`combine`, :func:`nonzero`, :func:`gather`,
:func:`scatter`) are shared the same way ("The CG's passes over the nodes on
the same threads").

The pool is made on first use and kept for the process; with one worker, or
an array of fewer than :data:`SHARED_VALUES` values, each pass is numpy's own
whole-array call in the calling thread: the blocks' closures and bounds cost
3–4 µs a call, as much as the pass itself on a 33² grid, where they made a
task of 12 loads 10–24 % slower. Only the calling thread submits work, and
no share submits any, so shares never wait on each other.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np
from scipy.linalg.blas import daxpy

from .set_blocks import set_sized

#: values of an array below which a pass runs in the calling thread: handing a share to another
#: thread costs about 20 µs, a pass over 2**18 float32 values about 100 µs
SHARED_VALUES = 1 << 18

_pool: ThreadPoolExecutor | None = None
_pool_threads = 0


def _executor(threads: int) -> ThreadPoolExecutor:
    """The process's pool, with at least ``threads`` threads (a smaller one is replaced: every
    earlier call has waited for its shares before returning)."""
    global _pool, _pool_threads
    if _pool is None or _pool_threads < threads:
        if _pool is not None:
            _pool.shutdown(wait=True)
        _pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="roughcontact-pass")
        _pool_threads = threads
    return _pool


def by_rows(workers: int, count: int, work) -> None:
    """``work(start, stop)`` over ``workers`` contiguous shares of ``range(count)`` (fewer where
    there are fewer rows), one of them in the calling thread. Returns, or raises the first
    error (the calling thread's first), only when every share has ended."""
    threads = min(workers, count)
    if threads <= 1:
        work(0, count)
        return
    bounds = np.linspace(0, count, threads + 1).astype(int)
    pool = _executor(threads - 1)
    futures = [pool.submit(work, int(a), int(b)) for a, b in zip(bounds[1:-1], bounds[2:])]
    try:
        work(int(bounds[0]), int(bounds[1]))
    finally:
        wait(futures)
    for future in futures:
        future.result()


def shares(target: np.ndarray, workers: int) -> int:
    """The threads a pass over ``target`` takes: one below SHARED_VALUES values (also for work
    elsewhere that is split by :func:`by_rows` by the size of what it writes)."""
    return workers if target.size >= SHARED_VALUES else 1


def _same_rows(target: np.ndarray, other: np.ndarray) -> bool:
    """Whether ``other`` can be sliced by rows with ``target``: the same leading length, not a
    broadcast (which numpy's whole-array operation handles)."""
    return np.ndim(other) == target.ndim and other.shape[0] == target.shape[0]


def fill(target: np.ndarray, value: float, workers: int) -> None:
    """target[...] = value, by blocks of its leading axis."""
    threads = shares(target, workers)
    if threads <= 1:
        target.fill(value)
        return
    by_rows(threads, target.shape[0], lambda a, b: target[a:b].fill(value))


def copy(target: np.ndarray, source: np.ndarray, workers: int) -> None:
    """target[...] = source, casting as numpy's assignment does; ``source`` must not overlap
    ``target`` (the blocks are written in any order)."""
    threads = shares(target, workers)
    if threads <= 1 or not _same_rows(target, source):
        np.copyto(target, source, casting="unsafe")
        return
    by_rows(threads, target.shape[0], lambda a, b: np.copyto(target[a:b], source[a:b], casting="unsafe"))


def scale(target: np.ndarray, factor, workers: int) -> None:
    """target *= factor, in place (``factor`` an array not overlapping ``target``, or a scalar):
    :func:`combine` with ``numpy.multiply``."""
    combine(np.multiply, target, factor, target, workers)


#: rows of the blocks of :func:`scale_summed`: each block is summed while it is in cache
SUMMED_ROWS = 16


def scale_summed(target: np.ndarray, factor: np.ndarray, workers: int) -> float:
    """target *= factor, in place (numpy's broadcasting of one row is not taken: ``factor`` has
    ``target``'s rows; a complex target may take a real factor), and, from the same blocks of
    SUMMED_ROWS rows while they are in cache, Σ t·(f t) over the values of ``target``'s real
    view (a complex value's real and imaginary parts): for a spectrum X and a real symbol λ,
    Σ λ |X|² (Parseval). Each block's sum is BLAS's dot in the block's precision (n terms, at
    most n · u of their sum off for positive terms), the blocks' are added in float64 in their
    order: the same bits whatever the threads, which split the blocks, not the rows."""
    if not _same_rows(target, factor):
        raise ValueError(f"scale_summed needs a factor of the target's rows, got {np.shape(factor)} "
                         f"for {target.shape}")
    real = target.view(target.real.dtype) if np.iscomplexobj(target) else target
    rows = target.shape[0]
    sums = np.zeros(-(-rows // SUMMED_ROWS))

    def work(first_block: int, last_block: int) -> None:
        block = np.empty((SUMMED_ROWS,) + target.shape[1:], dtype=target.dtype)
        for index in range(first_block, last_block):
            first, last = index * SUMMED_ROWS, min(index * SUMMED_ROWS + SUMMED_ROWS, rows)
            scaled = block[:last - first]
            np.multiply(target[first:last], factor[first:last], out=scaled)
            sums[index] = np.dot(real[first:last].reshape(-1), scaled.view(real.dtype).reshape(-1))
            target[first:last] = scaled

    by_rows(shares(target, workers), sums.size, work)
    return float(sums.sum())


def combine(ufunc, first: np.ndarray, second, out: np.ndarray, workers: int) -> np.ndarray:
    """out = ufunc(first, second) for a binary elementwise ufunc (``second`` an array of the same
    shape or a scalar), by blocks of the leading axis: each value is the same bits as numpy's
    whole-array call. Operands that broadcast are left to numpy whole. Returns ``out``."""
    threads = shares(out, workers)
    if threads <= 1 or not _same_rows(out, first) or (np.ndim(second) and not _same_rows(out, second)):
        return ufunc(first, second, out=out)
    part = _rows_of(second)
    by_rows(threads, out.shape[0], lambda a, b: ufunc(first[a:b], part(a, b), out=out[a:b]))
    return out


def _rows_of(operand):
    """``(a, b) -> operand[a:b]`` for an array, ``-> operand`` for a scalar."""
    return (lambda a, b: operand[a:b]) if np.ndim(operand) else (lambda a, b: operand)


def gather(source: np.ndarray, nodes: np.ndarray, workers: int, out: np.ndarray | None = None) -> np.ndarray:
    """source[nodes] (a 1-D ``source``; ``nodes`` valid indices, as made by ``numpy.flatnonzero``),
    into ``out`` (by default a new set-sized block, :func:`.set_blocks.set_sized`), by blocks of
    ``nodes``. numpy's ``take`` into an ``out`` buffers the whole result where it checks the
    indices (mode "raise"), which took twice the time of the gather itself; "clip" writes straight
    through, and on valid indices is the same gather."""
    threads = shares(nodes, workers)
    if out is None:
        out = set_sized(nodes.size, source.dtype)
    if threads <= 1:
        return np.take(source, nodes, out=out, mode="clip")
    by_rows(threads, nodes.size, lambda a, b: np.take(source, nodes[a:b], out=out[a:b], mode="clip"))
    return out


def add_scaled(target: np.ndarray, factor: float, values: np.ndarray) -> np.ndarray:
    """target + factor · values (float64), in place, in one pass (BLAS daxpy; numpy's scaling and
    then subtracting took two passes over N more, 20-25 ms of a 4096² iteration)."""
    return daxpy(values, target, a=factor) if target.size else target


def largest_magnitude(values: np.ndarray) -> float:
    """max |values|, 0 for none (NaN where any is NaN): the largest and the smallest value, two
    passes that allocate nothing, where ``numpy.abs(values).max()`` made a temporary of the
    values' size first (3.8 against 2.1 ms for 3.6 M values)."""
    return float(max(values.max(initial=0.0), -values.min(initial=0.0)))


def scatter(target: np.ndarray, nodes: np.ndarray, values, workers: int) -> None:
    """target[nodes] = values (a 1-D ``target``, ``nodes`` distinct, ``values`` of their length
    or a scalar), by blocks of ``nodes``: distinct nodes make the blocks' writes disjoint."""
    threads = shares(nodes, workers)
    if threads <= 1:
        target[nodes] = values
        return
    part = _rows_of(values)
    by_rows(threads, nodes.size, lambda a, b: target.__setitem__(nodes[a:b], part(a, b)))


#: masks with more than one node in this many set take numpy's own ``flatnonzero`` (a count and a
#: fill, 8 B a node written): shared between two threads their indices took longer, 1.24 against
#: 0.83 ms for 86 % of 2**20 nodes, where 2 % of 2**24 took 5.9 against 10.6 ms
DENSE_NONZERO = 4


def nonzero(mask: np.ndarray, workers: int) -> np.ndarray:
    """numpy.flatnonzero(mask) of a 1-D mask. A sparse mask's blocks are searched in their own
    threads, and each block's indices are then written at its offset into the one result
    (ascending, as numpy's). A dense mask (DENSE_NONZERO) is searched whole, as numpy's fill is
    the faster there and holds no second copy of its indices."""
    threads = shares(mask, workers)
    if threads <= 1:
        return np.flatnonzero(mask)
    count = int(np.count_nonzero(mask))
    if count > mask.size // DENSE_NONZERO:
        return np.flatnonzero(mask)
    bounds = np.linspace(0, mask.size, threads + 1).astype(np.intp)
    parts: list[np.ndarray | None] = [None] * threads

    def find(first: int, last: int) -> None:
        for share in range(first, last):
            parts[share] = np.flatnonzero(mask[bounds[share]:bounds[share + 1]])

    by_rows(threads, threads, find)
    offsets = np.concatenate(([0], np.cumsum([part.size for part in parts])))
    out = np.empty(count, dtype=np.intp)

    def place(first: int, last: int) -> None:
        for share in range(first, last):
            np.add(parts[share], bounds[share], out=out[offsets[share]:offsets[share + 1]])

    by_rows(threads, threads, place)
    return out
