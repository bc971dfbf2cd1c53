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
sets of nodes (:func:`kernel_block`, a gather).
"""
from __future__ import annotations

import numpy as np


def punch_kernel(shape: tuple[int, int], spacing: float, compliance: float,
                 rows: np.ndarray | None = None) -> np.ndarray:
    """Table K[|Δi|, |Δj|] of Eq. 10 for all offsets of a grid of ``shape``; ``rows``: only the
    rows |Δi| listed (a distributed operator computes the rows of its own slab, not the table)."""
    a = spacing / 2.0
    di = (np.arange(shape[0]) if rows is None else np.asarray(rows))[:, None] * spacing
    dj = np.arange(shape[1])[None, :] * spacing
    r = np.hypot(di, dj)
    with np.errstate(divide="ignore"):
        ratio = np.where(r > a, a / np.where(r > 0, r, 1.0), 1.0)
    return compliance / (2.0 * np.pi * a) * np.arcsin(ratio)


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


def offset_table(kernel: np.ndarray, periodic: bool = False) -> np.ndarray:
    """The kernel over signed offsets, as used by :func:`kernel_block`.

    Non-periodic: the mirrored table (:func:`mirrored_kernel`), (2nx − 1) × (2ny − 1),
    entry (nx − 1 + Δi, ny − 1 + Δj). Periodic: the period tiled twice along
    each axis, 2nx × 2ny, entry (nx + Δi, ny + Δj) for Δi ∈ (−nx, nx).
    """
    return np.tile(kernel, (2, 2)) if periodic else mirrored_kernel(kernel)


def kernel_block(table: np.ndarray, shape: tuple[int, int], row_nodes: np.ndarray, column_nodes: np.ndarray,
                 periodic: bool = False, out: np.ndarray | None = None, chunk: int = 1 << 22) -> np.ndarray:
    """H between two node sets, H[a, b] = K(i_a − i_b, j_a − j_b) (Eq. 10), from :func:`offset_table`.

    The flat index of an entry in the offset table is a row term minus a
    column term, so the (m, n) block is one integer subtraction and one
    gather per entry, in chunks of about ``chunk`` entries.
    """
    nx, ny = shape
    width = table.shape[1]
    base = (nx if periodic else nx - 1) * width + (ny if periodic else ny - 1)
    rows = base + row_nodes[:, 0].astype(np.int64) * width + row_nodes[:, 1]
    columns = column_nodes[:, 0].astype(np.int64) * width + column_nodes[:, 1]
    flat = table.ravel()
    m, n = rows.size, columns.size
    if out is None:
        out = np.empty((m, n))
    step = max(1, chunk // max(n, 1))
    for start in range(0, m, step):
        stop = min(m, start + step)
        # mode="clip": the indices are valid by construction, and numpy buffers take(out=) with "raise"
        np.take(flat, rows[start:stop, None] - columns[None, :], out=out[start:stop], mode="clip")
    return out
