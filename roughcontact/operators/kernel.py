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
once on the grid's offsets, mirrored to signed offsets, and each row is a
window of that table read at the footprint's nodes (a strided copy).
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
                   out: np.ndarray | None = None, block: int = 256) -> np.ndarray:
    """Rows of the flexibility matrix H (Eq. 10) over the footprint nodes.

    The row of node (i, j) is the window of the mirrored table whose origin
    sits on (i, j), read at the footprint's nodes: one strided copy per row
    instead of an indexed gather.

    Parameters
    ----------
    kernel
        Table from :func:`punch_kernel` (shape of the grid).
    footprint
        Boolean mask of the grid; the unknowns are its nodes in C order
        (``numpy.argwhere(footprint)``).
    rows
        Which rows (a slice of the unknowns) to build.
    out
        Optional output array (rows, N), any memory order.
    block
        Rows built in a C-ordered buffer before each copy into ``out``.
    """
    nx, ny = footprint.shape
    ext = mirrored_kernel(kernel)
    row_nodes = np.argwhere(footprint)[rows]
    n_rows, n = row_nodes.shape[0], int(footprint.sum())
    whole = bool(footprint.all())
    if out is None:
        out = np.empty((n_rows, n))
    buffer = np.empty((min(block, n_rows), n))
    for start in range(0, n_rows, block):
        stop = min(start + block, n_rows)
        for k, (i, j) in enumerate(row_nodes[start:stop]):
            window = ext[nx - 1 - i: 2 * nx - 1 - i, ny - 1 - j: 2 * ny - 1 - j]
            buffer[k] = window.ravel() if whole else window[footprint]
        out[start:stop] = buffer[: stop - start]
    return out
