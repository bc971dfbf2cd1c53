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
once on the grid's offsets and rows are gathered from the table, so assembling
a row costs one indexed read per entry.
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


def influence_rows(kernel: np.ndarray, nodes: np.ndarray, rows: slice | np.ndarray,
                   out: np.ndarray | None = None, block: int = 512) -> np.ndarray:
    """Rows of the flexibility matrix H (Eq. 10) restricted to ``nodes``.

    Parameters
    ----------
    kernel
        Table from :func:`punch_kernel`.
    nodes
        Integer array (N, 2) of the (i, j) indices of the footprint nodes, in
        the order of the unknowns.
    rows
        Which rows (indices into ``nodes``) to build.
    out
        Optional output array (len(rows), N), any memory order.
    block
        Rows built per vectorised pass, to bound temporaries.
    """
    row_nodes = nodes[rows]
    n_rows, n = row_nodes.shape[0], nodes.shape[0]
    if out is None:
        out = np.empty((n_rows, n))
    for start in range(0, n_rows, block):
        stop = min(start + block, n_rows)
        di = np.abs(row_nodes[start:stop, 0:1] - nodes[None, :, 0])
        dj = np.abs(row_nodes[start:stop, 1:2] - nodes[None, :, 1])
        out[start:stop] = kernel[di, dj]
    return out
