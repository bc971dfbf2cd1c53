"""A candidate for the solver's settled rate: a two-level preconditioner whose coarse products are cheap.

Deflating the CG by the blocks of the contact set (``bench_deflation --parts
solver``) gives the rate the iteration target needs, but its A Z costs one
fine FFT product per vector every time the set changes. Two changes make
that cheaper, measured by ``bench_deflation --parts twolevel``:

- **The balancing form** (Mandel's balancing Neumann–Neumann, in the
  notation of Tang, Nabben, Vuik and Erlangga, J. Sci. Comput. 39 (2009)
  340–370): P = Q + (I − Z E⁻¹ Wᵀ) M (I − W E⁻¹ Zᵀ), Q = Z E⁻¹ Zᵀ,
  E = Zᵀ W, with W = H Z. With the exact W its iterations are deflation's;
  unlike deflation's projection it stays symmetric positive definite for
  any W with Zᵀ W symmetric positive definite, so an approximate W (or one
  made on an earlier set) costs rate, never correctness.
- **W from a coarse product and an exact near field** (:class:`CheapProducts`):
  H z ≈ P H_c Pᵀ z + N z, with P the bilinear interpolation from the grid of
  every f-th node (H_c its operator, Eq. 10 at spacing f s) and N the
  difference H − P H_c Pᵀ kept at offsets of at most r nodes: one stencil
  per position of the source inside its coarse cell, f² of them, read from
  the kernel tables. A coarse product costs about 1/f² of a fine one; the
  near field, (2r + 1)² multiply-adds per node of the vector's support.
  Without N the approximation is within 1–5 % of H Z in the 2-norm but
  takes away most of the gain (the preconditioner magnifies the short
  wavelengths where the coarse product is wrong).
"""
from __future__ import annotations

import numpy as np

from roughcontact.normal import NormalProblem
from roughcontact.operators.kernel import punch_kernel
from roughcontact.surfaces import coarsen


def bilinear(nodes: np.ndarray, factor: int, coarse_shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(corners, weights), each (4, len(nodes)): the flat indices of the coarse nodes around each
    fine node (i, j) of the grid decimated by ``factor`` (coarse node (I, J) at fine (f I, f J)),
    and their bilinear weights; nodes beyond the last coarse row or column take its values."""
    parts = []
    for axis in (0, 1):
        count = coarse_shape[axis]
        low = np.minimum(nodes[:, axis] // factor, count - 1)
        share = np.where(low < count - 1, (nodes[:, axis] - low * factor) / factor, 0.0)
        high = np.minimum(low + 1, count - 1)
        parts.append(((low, 1.0 - share), (high, share)))
    corners, weights = [], []
    for i, wi in parts[0]:
        for j, wj in parts[1]:
            corners.append(i * coarse_shape[1] + j)
            weights.append(wi * wj)
    return np.array(corners), np.array(weights)


class CheapProducts:
    """H Z on the fixed set S for the columns of Z (disjoint supports, values on S), approximated
    by P H_c Pᵀ Z plus the exact near field at offsets of at most ``radius`` (the module's
    docstring). One rank, a footprint that is the whole grid."""

    def __init__(self, problem, topography, contact: np.ndarray, factor: int, radius: int):
        self.factor, self.radius = factor, radius
        nx, ny = topography.shape
        if problem.size != nx * ny or problem.comm.size != 1:
            raise ValueError("CheapProducts needs one rank and a footprint that is the whole grid")
        coarse_topography = coarsen(topography, factor, "decimate")
        self.coarse = NormalProblem(coarse_topography, problem.interface, problem.comm, operator="fft")
        self.coarse_shape = coarse_topography.shape
        nodes = problem.nodes[contact]
        self.corners, self.weights = bilinear(nodes, factor, self.coarse_shape)
        self.rows, self.columns = nodes[:, 0].astype(np.int64), nodes[:, 1].astype(np.int64)
        self.stencils = self._stencils(problem.flexibility.spacing, problem.flexibility.compliance)
        # the index on S of each node of the grid padded by the radius (−1: not on S)
        width = ny + 2 * radius
        self.width = width
        self.lookup = np.full((nx + 2 * radius) * width, -1, dtype=np.int64)
        self.lookup[(self.rows + radius) * width + self.columns + radius] = np.arange(contact.size)

    def _stencils(self, spacing: float, compliance: float) -> np.ndarray:
        """N[p, q, a + r, b + r] = H − P H_c Pᵀ between a source at (p, q) inside its coarse cell
        and the node (a, b) away from it, from the kernel tables of Eq. 10 at s and f s."""
        f, r = self.factor, self.radius
        base = f * (r // f + 2)                         # a source cell far enough from the window's edge
        span = base + f + r + 2
        cells = (2 * span // f + 2, 2 * span // f + 2)
        coarse_kernel = punch_kernel(cells, f * spacing, compliance)
        offsets = np.arange(-r, r + 1)
        exact = punch_kernel((r + 1, r + 1), spacing, compliance)[np.abs(offsets)[:, None], np.abs(offsets)]
        out = np.empty((f, f, 2 * r + 1, 2 * r + 1))
        for p in range(f):
            for q in range(f):
                source = np.array([[base + p, base + q]])
                targets = np.stack(np.meshgrid(base + p + offsets, base + q + offsets, indexing="ij"),
                                   axis=-1).reshape(-1, 2)
                s_corners, s_weights = bilinear(source, f, cells)
                t_corners, t_weights = bilinear(targets, f, cells)
                # (row, column) of each corner on the coarse grid: targets (4, m), the source (4, 1)
                ti, tj = np.divmod(t_corners, cells[1])
                si, sj = np.divmod(s_corners, cells[1])
                approx = np.zeros(targets.shape[0])
                for a in range(4):
                    for b in range(4):
                        approx += t_weights[a] * s_weights[b] * coarse_kernel[np.abs(ti[a] - si[b]),
                                                                              np.abs(tj[a] - sj[b])]
                out[p, q] = exact - approx.reshape(2 * r + 1, 2 * r + 1)
        return out

    def product(self, z: np.ndarray) -> np.ndarray:
        """≈ H z on S for z on S."""
        support = np.flatnonzero(z)
        values = z[support]
        restricted = np.bincount(self.corners[:, support].ravel(), (self.weights[:, support] * values).ravel(),
                                 minlength=self.coarse_shape[0] * self.coarse_shape[1])
        coarse = self.coarse.flexibility.product(restricted)
        out = (self.weights * coarse[self.corners]).sum(axis=0)
        f, r, width = self.factor, self.radius, self.width
        rows, columns = self.rows[support], self.columns[support]
        cells = (rows % f, columns % f)
        origin = (rows + r) * width + columns + r
        for a in range(-r, r + 1):
            for b in range(-r, r + 1):
                target = self.lookup[origin + a * width + b]
                on = target >= 0
                # distinct sources reach distinct targets at one offset: no repeated index
                out[target[on]] += self.stencils[cells[0][on], cells[1][on], a + r, b + r] * values[on]
        return out

    def destroy(self) -> None:
        self.coarse.destroy()


def balancing(precondition, basis: np.ndarray, products: np.ndarray):
    """The balancing preconditioner Q + (I − Z E⁻¹ Wᵀ) M (I − W E⁻¹ Zᵀ) for Z = ``basis``,
    W = ``products`` (≈ H Z) and M = ``precondition``; E = Zᵀ W made symmetric."""
    coarse = basis.T @ products
    inverse = np.linalg.inv(0.5 * (coarse + coarse.T))

    def apply(values):
        a = inverse @ (basis.T @ values)
        y = precondition(values - products @ a)
        return basis @ a + y - basis @ (inverse @ (products.T @ y))

    return apply
