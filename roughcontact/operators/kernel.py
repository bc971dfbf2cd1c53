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


def punch_kernel(shape: tuple[int, int], spacing: float, compliance: float) -> np.ndarray:
    """Table K[|Δi|, |Δj|] of Eq. 10 for all offsets of a grid of ``shape``."""
    a = spacing / 2.0
    di = np.arange(shape[0])[:, None] * spacing
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


def kernel_block(kernel: np.ndarray, row_nodes: np.ndarray, column_nodes: np.ndarray,
                 periodic_shape: tuple[int, int] | None = None, out: np.ndarray | None = None,
                 chunk: int = 1 << 22) -> np.ndarray:
    """H between two node sets, H[a, b] = K[|i_a − i_b|, |j_a − j_b|] (Eq. 10).

    ``row_nodes`` and ``column_nodes`` are (m, 2) and (n, 2) arrays of grid
    indices; the (m, n) block is gathered from the table in chunks of about
    ``chunk`` entries so the index temporaries stay small. With
    ``periodic_shape`` the table is a periodic kernel over one period and is
    read at the offsets modulo the period.
    """
    ny = kernel.shape[1]
    flat = kernel.ravel()
    m, n = row_nodes.shape[0], column_nodes.shape[0]
    if out is None:
        out = np.empty((m, n))
    ci = column_nodes[:, 0].astype(np.int64)
    cj = column_nodes[:, 1].astype(np.int64)
    step = max(1, chunk // max(n, 1))
    for start in range(0, m, step):
        stop = min(m, start + step)
        di = row_nodes[start:stop, 0, None].astype(np.int64) - ci
        dj = row_nodes[start:stop, 1, None].astype(np.int64) - cj
        if periodic_shape is None:
            np.abs(di, out=di)
            np.abs(dj, out=dj)
        else:
            np.mod(di, periodic_shape[0], out=di)
            np.mod(dj, periodic_shape[1], out=dj)
        di *= ny
        di += dj
        np.take(flat, di, out=out[start:stop])
    return out
