"""The Eq. 10 kernel summed over the images of a periodic cell (the ``fft-periodic`` operator).

A surface declared periodic is one cell of a doubly periodic interface; the
displacement at a node is the sum of the punch kernel K (Eq. 10) over the
node's offsets to every image of every loaded punch,

    k_per(x) = Σ_m K(|x + L m|),    m ∈ Z²,  L m = (m_x L_x, m_y L_y).

This keeps the discretisation of the non-periodic operator (a rigid punch of
radius a = s/2 per node, self term A/(4a)), which is what makes its contact
area accurate at coarse grids; the Fourier half-space stiffness E*|q|/2 of
point forces would change the near field. The sum diverges like Σ 1/|m|
(a net load on every cell), which only shifts the mean displacement: the
operator is taken in the gauge where the mean of k_per over the nodes of the
cell is zero, so H has the constant vector as null space (load control fixes
the mean approach; displacement control is not defined).

Evaluation, at offsets taken to the nearest image (x in [−L/2, L/2], so the
table is even by construction): K = G + D with G(r) = A/(2πr), the point
force, and D = K − G = A/(2πa)(arcsin(a/r) − a/r) ≈ A a²/(12π r³), which is
summed directly over the images |m| ≤ 2. Its tail beyond them,
≈ A a²/(12π L³) Σ_{|m|>2} |m|⁻³, is a constant (removed with the gauge) up
to a variation over the cell of about 1/(100 n³) of the self term A/(4a):
1e-8 at n = 32, 1e-11 at n = 512. The lattice sum of G is an Ewald sum (Parry, Surf. Sci. 49 (1975) 433; the 2-D periodic
Coulomb sum evaluated in its plane):

    Σ_m 1/|x + Lm| = Σ_m erfc(α|x + Lm|)/|x + Lm|
                     + (2π / L_x L_y) Σ_{k≠0} erfc(|k|/2α)/|k| e^{i k·x}
                     − 2√π / (α L_x L_y),

with k = 2π (j_x/L_x, j_y/L_y). The result does not depend on α (a test).
α min(L) = min(6, π n/12) makes the Fourier terms beyond the grid's Nyquist
mode negligible (erfc(6) ≈ 2e-17), so the Fourier sum is one FFT on the grid,
and the real-space sum runs over the images |m| ≤ ⌈6/(α min L)⌉ (the
nearest ones for grids of 23 nodes or more).
At x = 0 the m = 0 term is the punch itself: K(0) replaces it and the smooth
part erf(αr)/r → 2α/√π that the Fourier sum contains is removed.
"""
from __future__ import annotations

import numpy as np
from scipy.special import erfc

from .kernel import punch_kernel

#: erfc(CUTOFF) ≈ 2e-17: Ewald terms beyond it are dropped
CUTOFF = 6.0


def ewald_parameter(shape: tuple[int, int]) -> float:
    """α min(L_x, L_y): as large as the grid's Nyquist mode allows, at most CUTOFF."""
    return min(CUTOFF, np.pi * min(shape) / (2.0 * CUTOFF))


def nearest_image_offsets(shape: tuple[int, int], spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (x, y) of the table entries taken to the nearest image: i s or (i − n) s."""
    nx, ny = shape
    i, j = np.arange(nx), np.arange(ny)
    x = np.where(i <= nx // 2, i, i - nx) * spacing
    y = np.where(j <= ny // 2, j, j - ny) * spacing
    return x[:, None], y[None, :]


def lattice_coulomb(shape: tuple[int, int], spacing: float, alpha_l: float | None = None) -> np.ndarray:
    """Σ_m 1/|x + L m| at the grid offsets x (zero mean over the continuous cell; m = 0 left out at x = 0), 1/m.

    ``alpha_l`` = α min(L_x, L_y), default :func:`ewald_parameter`.
    """
    nx, ny = shape
    lx, ly = nx * spacing, ny * spacing
    area = lx * ly
    alpha_l = ewald_parameter(shape) if alpha_l is None else alpha_l
    alpha = alpha_l / min(lx, ly)
    images = int(np.ceil(CUTOFF / alpha_l))
    x, y = nearest_image_offsets(shape, spacing)
    real = np.zeros(shape)
    for mx in range(-images, images + 1):
        for my in range(-images, images + 1):
            r = np.hypot(x + mx * lx, y + my * ly)
            with np.errstate(divide="ignore", invalid="ignore"):
                term = erfc(alpha * r) / r
            if mx == 0 and my == 0:
                term[0, 0] = 0.0
            real += term
    # Fourier part on the grid: coefficients (2π/area) erfc(|k|/2α)/|k| on the modes |j| ≤ jmax
    kx = 2.0 * np.pi * np.fft.fftfreq(nx, d=spacing)
    ky = 2.0 * np.pi * np.fft.fftfreq(ny, d=spacing)
    k = np.hypot(kx[:, None], ky[None, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        coefficients = np.where(k > 0.0, 2.0 * np.pi / area * erfc(k / (2.0 * alpha)) / np.where(k > 0, k, 1), 0.0)
    fourier = np.fft.ifft2(coefficients).real * (nx * ny)
    out = real + fourier - 2.0 * np.sqrt(np.pi) / (alpha * area)
    out[0, 0] -= 2.0 * alpha / np.sqrt(np.pi)
    return out


def periodic_kernel(shape: tuple[int, int], spacing: float, compliance: float,
                    alpha_l: float | None = None) -> np.ndarray:
    """k_per[i, j]: the Eq. 10 kernel summed over the images of the cell, zero mean over the nodes.

    Indexed by the offset (i, j) modulo the period (an (nx, ny) table).
    """
    nx, ny = shape
    lx, ly = nx * spacing, ny * spacing
    a = spacing / 2.0
    x, y = nearest_image_offsets(shape, spacing)
    correction = np.zeros(shape)
    for mx in range(-2, 3):
        for my in range(-2, 3):
            r = np.hypot(x + mx * lx, y + my * ly)
            with np.errstate(divide="ignore", invalid="ignore"):
                d = compliance / (2.0 * np.pi * a) * (np.arcsin(np.minimum(1.0, a / r)) - a / r)
            if mx == 0 and my == 0:
                d[0, 0] = 0.0
            correction += d
    table = compliance / (2.0 * np.pi) * lattice_coulomb(shape, spacing, alpha_l) + correction
    table[0, 0] += punch_kernel((1, 1), spacing, compliance)[0, 0]
    table -= table.mean()
    return table
