"""Influence coefficients of the shear tractions (Eqs. 15–16) on the punch grid of Eq. 10.

Eqs. 15–16 (β = 0) give the relative tangential displacement of node i under
point forces q_j; in tensor form (Cerruti's solution for two bodies, Johnson
1985 Eq. 2.19 at z = 0)

    u_i = A / (2π r) [δ + γ r̂ r̂] q_j,        r = x_i − x_j,

with A the composite compliance (Eq. 4a) and γ the composite Poisson ratio
(Eq. 4b). The cross term is + γ Δx Δy / r³: the only sign that keeps the
kernel a rotation-invariant tensor (the paper prints it with a minus).

Discretisation: as in Eq. 10, each node is a rigid circular punch of radius
a = s/2, now loaded tangentially: its traction q_j / (2π a √(a² − ρ²)) keeps
the displacement of the disc uniform (Johnson 1985 §3.8 and Eq. 7.40), and
the displacement at the centre of node i is, with R = |r|,

    T(R) = (1 + γ/2) K(R) δ + γ A/(4π) D(R) (2 R̂ R̂ − δ),
    K(R) = A/(2π a) arcsin(min(1, a/R))            (Eq. 10, the normal kernel),
    D(R) = √(R² − a²) / R²  (R > a),   0  (R ≤ a),

D(R) = ∫₀^∞ sin(ka)/(ka) J₂(kR) dk (Gradshteyn & Ryzhik 6.693.1) being the
punch-weighted deviatoric part of 1/r. So T_xx = (1 + γ/2) K + γ A/(4π) D
(Δx² − Δy²)/R², T_yy the same with the sign of the last term reversed,
T_xy = γ A/(2π) D Δx Δy / R², and the self term T_xx = T_yy = (1 + γ/2) A/(4a)
(Johnson's (2 − ν)/(4G) π q₀ a). At γ = 0 the tangential kernel is the normal
one, so the coupled solve reduces exactly to the paper's Eqs. 17–18.

On the grid T_xx and T_yy are even in each offset, T_xy odd in each: the
first two have real symbols (:meth:`SlabConvolution.set_kernel`), and so has
T_xy, the sine–sine transform −4 Σ T_xy sin(kx Δi) sin(ky Δj), computed here
from the transform of its quadrant (:func:`odd_symbol`).
"""
from __future__ import annotations

import numpy as np

from .convolution import SlabConvolution
from .kernel import punch_kernel


def shear_kernels(shape: tuple[int, int], spacing: float, compliance: float,
                  gamma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tables (T_xx, T_yy, T_xy)[Δi, Δj] for offsets Δi, Δj ≥ 0 of a grid of ``shape`` (m/N).

    Parameters
    ----------
    shape
        (nx, ny) of the grid.
    spacing
        Grid spacing s (m); punches of radius s/2.
    compliance
        Composite compliance A (Eq. 4a), m²/N.
    gamma
        Composite Poisson ratio γ (Eq. 4b).
    """
    a = spacing / 2.0
    di = np.arange(shape[0])[:, None] * spacing
    dj = np.arange(shape[1])[None, :] * spacing
    r2 = di**2 + dj**2
    outside = r2 > a * a
    safe = np.where(outside, r2, 1.0)
    deviatoric = np.where(outside, np.sqrt(np.maximum(r2 - a * a, 0.0)) / safe**2, 0.0)   # D(R) / R²
    normal = punch_kernel(shape, spacing, compliance)          # K(R), Eq. 10
    scale = gamma * compliance / (4.0 * np.pi)
    difference = scale * deviatoric * (di**2 - dj**2)
    xx = (1.0 + gamma / 2.0) * normal + difference
    yy = (1.0 + gamma / 2.0) * normal - difference
    xy = 2.0 * scale * deviatoric * di * dj
    return xx, yy, xy


def signed_offsets(tables: tuple[np.ndarray, np.ndarray, np.ndarray], di: np.ndarray,
                   dj: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(T_xx, T_yy, T_xy) at signed offsets (Δi, Δj): T_xy is odd in each offset."""
    xx, yy, xy = tables
    i, j = np.abs(di), np.abs(dj)
    return xx[i, j], yy[i, j], np.sign(di) * np.sign(dj) * xy[i, j]


def odd_symbol(convolution: SlabConvolution, table: np.ndarray) -> np.ndarray:
    """The real symbol of a kernel odd in each offset, k(±Δi, ±Δj) = ±·± table[Δi, Δj].

    With F the transform of the quadrant (``table`` placed at offsets ≥ 0,
    :meth:`SlabConvolution.forward`), the four quadrants sum to
    F(kx, ky) − F(−kx, ky) − F(kx, −ky) + F(−kx, −ky) = 2 Re F(kx, ky) − 2 Re F(−kx, ky)
    for a real table; −kx is a row of the same rank's columns. The table's
    first row and column vanish (the kernel is odd), so no offset is counted twice.
    Returns this rank's block (Lx, my columns), odd in kx: :class:`ShearConvolution` keeps it
    beside the even ones (a :class:`SlabConvolution` holds only even symbols).
    """
    r0, r1 = convolution.rows
    spectrum = convolution.forward(np.ascontiguousarray(table[r0:r1]))
    flipped = (-np.arange(convolution.lengths[0])) % convolution.lengths[0]
    real = spectrum.real
    return 2.0 * (real - real[flipped])


class ShearConvolution:
    """(u_x, u_y) = T ⊛ (q_x, q_y) (Eqs. 15–16) on a grid whose rows are split over ``comm``.

    Three symbols on one zero-padded :class:`SlabConvolution` (a half-space,
    no wrap-around): a product is two forward and two inverse transforms.

    Parameters
    ----------
    shape, spacing, compliance, gamma
        As :func:`shear_kernels`.
    comm
        mpi4py communicator (rows as :func:`~.convolution.split`).
    workers
        FFT threads per rank.
    """

    def __init__(self, shape: tuple[int, int], spacing: float, compliance: float, gamma: float, comm,
                 workers: int | None = None):
        self.tables = shear_kernels(shape, spacing, compliance, gamma)
        self.convolution = SlabConvolution(shape, comm, periodic=False, workers=workers)
        symbols = []
        for table in self.tables[:2]:
            self.convolution.set_kernel(table)
            symbols.append(self.convolution.symbol)
        symbols.append(odd_symbol(self.convolution, self.tables[2]))
        self.symbols = tuple(np.ascontiguousarray(s) for s in symbols)
        self.convolution.release_symbol()
        self.rows = self.convolution.rows

    def apply(self, qx: np.ndarray, qy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u_x, u_y) on this rank's rows for (q_x, q_y) on them, each (rows, ny)."""
        sxx, syy, sxy = self.symbols
        fx = np.array(self.convolution.forward(qx))            # a copy: forward reuses its buffer
        fy = self.convolution.forward(qy)
        ux = self.convolution.backward(sxx * fx + sxy * fy)
        uy = self.convolution.backward(sxy * fx + syy * fy)
        return ux, uy
