"""Influence coefficients of rigid circular punches on a square grid (Eq. 10).

Each grid node is the centre of a rigid circular punch of radius a = s/2.
A unit force on the punch at node j displaces the surface at node i by

    H_ij = A / (2 π a) · arcsin(a / r_ij)        (r_ij ≥ a)
    H_ii = A / (4 a)                             (r = 0: the punch itself)

with A the composite compliance (Eq. 4a; (1 − ν)/μ for one elastic body,
as written in Eq. 10). The r = 0 term is the rigid-punch settlement, which is
the limit arcsin(1) = π/2 of the same formula, so the kernel is evaluated with
arcsin(min(1, a/r)).

On a regular grid H_ij depends only on (|Δi|, |Δj|): the kernel is tabulated
once on the grid's offsets (:func:`punch_kernel`). Blocks of H are read from
that table: whole rows as windows of the table mirrored to signed offsets
(:func:`influence_rows`, a strided copy per row), or the entries between two
sets of nodes (:func:`kernel_block`, a gather). Where the table would be too
large to hold on every rank, the entries between two sets of nodes are the
formula evaluated at their offsets (:func:`punch_block`), the same bits.
"""
from __future__ import annotations

import numpy as np

from . import passes

#: entries of the table computed at once by :func:`punch_kernel` (1 MiB of float64)
TABLE_CHUNK = 1 << 17


def punch_kernel(shape: tuple[int, int], spacing: float, compliance: float,
                 rows: np.ndarray | None = None, workers: int = 1) -> np.ndarray:
    """Table K[|Δi|, |Δj|] of Eq. 10 for all offsets of a grid of ``shape``; ``rows``: only the
    rows |Δi| listed (a distributed operator computes the rows of its own slab, not the table);
    ``workers``: threads sharing the rows (each entry the same bits; numpy's ``hypot`` and
    ``arcsin`` release the GIL: a 4096² operator's and preconditioner's tables took 0.63 s of a
    37.9 s solve on one thread)."""
    di = (np.arange(shape[0]) if rows is None else np.asarray(rows))[:, None]
    dj = np.arange(shape[1])[None, :]
    table = np.empty((di.shape[0], shape[1]))
    # by chunks of rows: the formula's temporaries (three or four of a chunk's size) stay small,
    # where those of whole shares, made in the pool's threads, stayed resident in their heaps
    # (near full contact at 1024², 10-14 B per node more at the solve's peak)
    step = max(1, TABLE_CHUNK // max(shape[1], 1))
    chunks = -(-di.shape[0] // step)

    def work(first: int, last: int) -> None:
        for chunk in range(first, last):
            a, b = chunk * step, min(chunk * step + step, di.shape[0])
            punch_entries(di[a:b], dj, spacing, compliance, out=table[a:b])

    passes.by_rows(passes.shares(table, workers), chunks, work)
    return table


def punch_entries(di: np.ndarray, dj: np.ndarray, spacing: float, compliance: float,
                  out: np.ndarray | None = None) -> np.ndarray:
    """Eq. 10 at integer offsets (|Δi|, |Δj|) (arrays broadcast together): the table's formula entry
    by entry, so the same bits as :func:`punch_kernel`'s entries."""
    a = spacing / 2.0
    r = np.hypot(di * spacing, dj * spacing)
    with np.errstate(divide="ignore"):
        ratio = np.where(r > a, a / np.where(r > 0, r, 1.0), 1.0)
    return np.multiply(compliance / (2.0 * np.pi * a), np.arcsin(ratio, out=ratio), out=out)


def mirrored_kernel(kernel: np.ndarray) -> np.ndarray:
    """The table over signed offsets: ext[a, b] = K[|a − (nx − 1)|, |b − (ny − 1)|]."""
    nx, ny = kernel.shape
    ext = np.empty((2 * nx - 1, 2 * ny - 1))
    ext[nx - 1:, ny - 1:] = kernel
    ext[: nx - 1, ny - 1:] = kernel[:0:-1, :]
    ext[nx - 1:, : ny - 1] = kernel[:, :0:-1]
    ext[: nx - 1, : ny - 1] = kernel[:0:-1, :0:-1]
    return ext


def influence_rows(kernel: np.ndarray, footprint: np.ndarray, rows: slice,
                   columns: tuple[int, int] | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """Rows of the flexibility matrix H (Eq. 10) over the footprint nodes.

    The row of node (i, j) is the window of the mirrored table whose origin
    sits on (i, j), read at the footprint's nodes, written straight into
    ``out``: one strided copy per grid row when its nodes are all wanted and
    the columns are whole rows (the windows of consecutive nodes are sliding
    windows of one band of the table), one per node otherwise.

    Parameters
    ----------
    kernel
        Table from :func:`punch_kernel` (shape of the grid).
    footprint
        Boolean mask of the grid; the unknowns are its nodes in C order
        (``numpy.argwhere(footprint)``).
    rows
        Which rows (a slice of the unknowns) to build.
    columns
        Restrict the columns to the footprint nodes of grid rows
        [start, stop) (default: all nodes).
    out
        Optional C-ordered output array (rows, columns).
    """
    nx, ny = footprint.shape
    ext = mirrored_kernel(kernel)
    row_nodes = np.argwhere(footprint)[rows]
    c0, c1 = (0, nx) if columns is None else columns
    mask = footprint[c0:c1]
    whole = bool(mask.all())
    if out is None:
        out = np.empty((row_nodes.shape[0], int(mask.sum())))
    k = 0
    while k < row_nodes.shape[0]:
        i = row_nodes[k, 0]
        # the rows of all ny nodes of grid row i, when they are all wanted, are one strided view:
        # windows[j] = ext[.., ny − 1 − j : 2 ny − 1 − j] (sliding windows read backwards)
        if whole and k + ny <= row_nodes.shape[0] and row_nodes[k, 1] == 0 and row_nodes[k + ny - 1, 1] == ny - 1 \
                and footprint[i].all():
            band = ext[nx - 1 - i + c0: nx - 1 - i + c1]
            windows = np.lib.stride_tricks.sliding_window_view(band, ny, axis=1)[:, ::-1, :]
            out[k:k + ny].reshape(ny, c1 - c0, ny)[...] = windows.transpose(1, 0, 2)
            k += ny
            continue
        j = row_nodes[k, 1]
        window = ext[nx - 1 - i + c0: nx - 1 - i + c1, ny - 1 - j: 2 * ny - 1 - j]
        if whole:
            out[k].reshape(mask.shape)[...] = window
        else:
            out[k] = window[mask]
        k += 1
    return out


#: entries of a block made at once: bounds the block's index and formula temporaries (about 2 MiB
#: each) whatever the block's size
BLOCK_CHUNK = 1 << 18


def _offset_chunks(row_nodes: np.ndarray, column_nodes: np.ndarray, out: np.ndarray, chunk: int):
    """(rows of ``out``, Δi, Δj) for each chunk of about ``chunk`` entries of the block between two
    node sets: the chunk's signed offsets i_a − i_b, j_a − j_b (int64, the caller's to overwrite)."""
    i_rows, j_rows = (row_nodes[:, k].astype(np.int64) for k in (0, 1))
    i_columns, j_columns = (column_nodes[:, k].astype(np.int64) for k in (0, 1))
    step = max(1, chunk // max(out.shape[1], 1))
    for start in range(0, out.shape[0], step):
        stop = min(out.shape[0], start + step)
        yield (out[start:stop], np.subtract(i_rows[start:stop, None], i_columns[None, :]),
               np.subtract(j_rows[start:stop, None], j_columns[None, :]))


def kernel_block(table: np.ndarray, shape: tuple[int, int], row_nodes: np.ndarray, column_nodes: np.ndarray,
                 periodic: bool = False, out: np.ndarray | None = None, chunk: int = BLOCK_CHUNK) -> np.ndarray:
    """H between two node sets, H[a, b] = K(i_a − i_b, j_a − j_b) (Eq. 10), read from ``table``.

    Non-periodic: ``table`` is K[|Δi|, |Δj|] (:func:`punch_kernel`), read at |Δi| · ny + |Δj|.
    Periodic: the kernel on one period, read at the offsets modulo the period. Integer index
    arithmetic and one gather per entry, in chunks of about ``chunk`` entries. (The table mirrored
    to signed offsets, four times the size, made the index one subtraction; the reads took as long.)
    """
    nx, ny = shape
    flat = table.ravel()
    if out is None:
        out = np.empty((row_nodes.shape[0], column_nodes.shape[0]))
    for block, di, dj in _offset_chunks(row_nodes, column_nodes, out, chunk):
        if periodic:
            np.mod(di, nx, out=di)
            np.mod(dj, ny, out=dj)
        else:
            np.abs(di, out=di)
            np.abs(dj, out=dj)
        di *= ny
        di += dj
        # mode="clip": the indices are valid by construction, and numpy buffers take(out=) with "raise"
        np.take(flat, di, out=block, mode="clip")
    return out


def punch_block(spacing: float, compliance: float, row_nodes: np.ndarray, column_nodes: np.ndarray,
                out: np.ndarray | None = None, chunk: int = BLOCK_CHUNK) -> np.ndarray:
    """H between two node sets from Eq. 10 evaluated at each entry's offsets (:func:`punch_entries`):
    the entries :func:`kernel_block` reads from the table, bit for bit, without a table of the
    grid's size (about four times the time of the reads: 80 against 20 ns an entry for blocks of
    1 448 and 3 810 nodes of a 1024² grid). In chunks of about ``chunk`` entries."""
    if out is None:
        out = np.empty((row_nodes.shape[0], column_nodes.shape[0]))
    for block, di, dj in _offset_chunks(row_nodes, column_nodes, out, chunk):
        punch_entries(np.abs(di, out=di), np.abs(dj, out=dj), spacing, compliance, out=block)
    return out
