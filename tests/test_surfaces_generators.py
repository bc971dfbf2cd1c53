"""Random midpoint displacement and Fourier-filtered surfaces: algorithm, normalisation, reproducibility.

Known truths used here:
- on a 3 x 3 grid, Saupe's MidPointFM2D is short enough to redo by hand from
  the raw PCG64 draws (corners, centre, four edge midpoints);
- a Fourier-filtered surface is Re(IDFT(DFT(noise) * sqrt(C(q)))) with the
  spectrum of the module docstring, which a naive O(N^2) DFT reproduces;
- the normalisation to a given rms height or slope is exact to rounding.
"""
from __future__ import annotations

import hashlib

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.surfaces import fourier_surface, midpoint_surface, rms_height, rms_slope
from roughcontact.surfaces.midpoint import check_fractal_dimension, midpoint_heights

# --------------------------------------------------------------------------- midpoint


@pytest.mark.parametrize("dimension", [2.1, 2.5, 2.9])
def test_midpoint_three_by_three_follows_saupe(dimension):
    """One level of diamond-square, rebuilt from the raw random stream (exact arithmetic)."""
    hurst = 3.0 - dimension
    rng = np.random.default_rng(11)
    corners = rng.standard_normal((2, 2))
    d1 = 0.5 ** (0.5 * hurst)
    centre = corners.mean() + d1 * rng.standard_normal((1, 1))[0, 0]
    d2 = d1 * 0.5 ** (0.5 * hurst)
    z = np.zeros((3, 3))
    z[::2, ::2] = corners
    z[1, 1] = centre
    # square step, first the edge midpoints (1, 0), (1, 2), then (0, 1), (2, 1); 3 neighbours at the border
    east_west = rng.standard_normal((1, 2))
    z[1, 0] = (z[0, 0] + z[2, 0] + z[1, 1]) / 3 + d2 * east_west[0, 0]
    z[1, 2] = (z[0, 2] + z[2, 2] + z[1, 1]) / 3 + d2 * east_west[0, 1]
    north_south = rng.standard_normal((2, 1))
    z[0, 1] = (z[0, 0] + z[0, 2] + z[1, 1]) / 3 + d2 * north_south[0, 0]
    z[2, 1] = (z[2, 0] + z[2, 2] + z[1, 1]) / 3 + d2 * north_south[1, 0]
    expected = z - z.mean()
    np.testing.assert_allclose(midpoint_heights(1, dimension, seed=11), expected, rtol=0, atol=1e-14)


def test_midpoint_decimation_is_the_coarser_level():
    """Without random additions nodes never move once placed, and each level draws the same numbers:
    the (2^L+1) surface sampled every 2^k nodes equals the (2^(L-k)+1) surface (up to the mean)."""
    fine = midpoint_heights(7, 2.3, seed=5)
    coarse = midpoint_heights(4, 2.3, seed=5)
    sampled = fine[::8, ::8]
    np.testing.assert_allclose(sampled - sampled.mean(), coarse - coarse.mean(), rtol=0, atol=1e-13)


def test_midpoint_three_by_three_with_random_additions_follows_saupe():
    """Successive random additions (Saupe's MidPointFM2D, ``addition`` true): after the diamond step
    the old corners get an addition; after the square step the corners and the centre do, the new
    edge midpoints do not."""
    hurst = 0.6
    rng = np.random.default_rng(4)
    z = np.zeros((3, 3))
    z[::2, ::2] = rng.standard_normal((2, 2))
    d1 = 0.5 ** (0.5 * hurst)
    z[1, 1] = z[::2, ::2].mean() + d1 * rng.standard_normal((1, 1))[0, 0]
    z[::2, ::2] += d1 * rng.standard_normal((2, 2))
    d2 = d1 * 0.5 ** (0.5 * hurst)
    g = rng.standard_normal((1, 2))
    z[1, 0] = (z[0, 0] + z[2, 0] + z[1, 1]) / 3 + d2 * g[0, 0]
    z[1, 2] = (z[0, 2] + z[2, 2] + z[1, 1]) / 3 + d2 * g[0, 1]
    g = rng.standard_normal((2, 1))
    z[0, 1] = (z[0, 0] + z[0, 2] + z[1, 1]) / 3 + d2 * g[0, 0]
    z[2, 1] = (z[2, 0] + z[2, 2] + z[1, 1]) / 3 + d2 * g[1, 0]
    z[::2, ::2] += d2 * rng.standard_normal((2, 2))
    z[1, 1] += d2 * rng.standard_normal((1, 1))[0, 0]
    np.testing.assert_allclose(midpoint_heights(1, 3.0 - hurst, seed=4, random_additions=True),
                               z - z.mean(), rtol=0, atol=1e-14)


def test_midpoint_rms_normalisation_is_exact():
    t = midpoint_surface(6, 2.4, spacing=1e-4, rms_height=3e-6, seed=2)
    assert rms_height(t) == pytest.approx(3e-6, rel=1e-12)
    t = midpoint_surface(6, 2.4, spacing=1e-4, rms_slope=0.2, seed=2)
    assert rms_slope(t) == pytest.approx(0.2, rel=1e-12)
    # default amplitude: unit-σ corners times the spacing
    np.testing.assert_allclose(midpoint_surface(5, 2.4, spacing=2e-3, seed=1).heights,
                               2e-3 * midpoint_heights(5, 2.4, seed=1), rtol=1e-15)


@pytest.mark.parametrize("bad", [2.0, 3.0, 1.5, 3.2, float("nan"), "x", None, True])
def test_fractal_dimension_outside_open_interval_is_rejected(bad):
    with pytest.raises(InputError) as err:
        midpoint_surface(4, bad)
    assert err.value.parameter == "fractal_dimension"
    with pytest.raises(InputError):
        check_fractal_dimension(bad)
    with pytest.raises(InputError) as err:
        fourier_surface(16, fractal_dimension=bad, rms_height=1.0)
    # None means "not given": then neither Δ nor H is, and the error names hurst
    assert err.value.parameter == ("hurst" if bad is None else "fractal_dimension")


@pytest.mark.parametrize("kwargs, parameter", [
    (dict(levels=0), "levels"), (dict(levels=-2), "levels"), (dict(levels=2.5), "levels"),
    (dict(levels=None), "levels"), (dict(levels=15), "levels"),
    (dict(spacing=0.0), "spacing"), (dict(spacing=-1e-3), "spacing"), (dict(spacing=float("inf")), "spacing"),
    (dict(rms_height=0.0), "rms_height"), (dict(rms_height=-1.0), "rms_height"),
    (dict(rms_height=1.0, rms_slope=0.1), "rms_slope"),
    (dict(seed=-1), "seed"), (dict(seed=1.5), "seed"), (dict(seed=None), "seed"),
    (dict(random_additions="yes"), "random_additions"),
])
def test_midpoint_bad_arguments_name_the_parameter(kwargs, parameter):
    args = dict(levels=4, fractal_dimension=2.3, spacing=1.0)
    args.update(kwargs)
    with pytest.raises(InputError) as err:
        midpoint_surface(**args)
    assert err.value.parameter == parameter


# --------------------------------------------------------------------------- Fourier


def _naive_filtered(noise, spacing, hurst, q_rolloff, q_short):
    """The spectral filter written out with explicit DFT matrices (no numpy.fft)."""
    nx, ny = noise.shape
    fx = np.exp(-2j * np.pi * np.outer(np.arange(nx), np.arange(nx)) / nx)
    fy = np.exp(-2j * np.pi * np.outer(np.arange(ny), np.arange(ny)) / ny)
    spectrum = fx @ noise @ fy.T
    kx = np.where(np.arange(nx) <= nx // 2, np.arange(nx), np.arange(nx) - nx)
    ky = np.where(np.arange(ny) <= ny // 2, np.arange(ny), np.arange(ny) - ny)
    q = 2 * np.pi * np.hypot(kx[:, None] / (nx * spacing), ky[None, :] / (ny * spacing))
    amplitude = np.zeros_like(q)
    ok = (q > 0) & (q <= q_short)
    amplitude[ok] = np.maximum(q[ok], q_rolloff) ** (-(1 + hurst))
    return np.real(fx.conj() @ (spectrum * amplitude) @ fy.conj().T) / (nx * ny)


@pytest.mark.parametrize("shape", [(8, 6), (9, 7)])
def test_fourier_surface_is_the_filtered_noise(shape):
    """Same random draws, same filter, an independent transform: equal to 1e-12 relative
    (rounding of two different O(N^2) and O(N log N) transforms)."""
    spacing, hurst = 0.5, 0.7
    lambda_r, lambda_s = 3.0, 1.2
    t = fourier_surface(shape, spacing, hurst=hurst, rms_height=1.0, rolloff_wavelength=lambda_r,
                        short_cutoff_wavelength=lambda_s, seed=3)
    noise = np.random.default_rng(3).standard_normal(shape)
    expected = _naive_filtered(noise, spacing, hurst, 2 * np.pi / lambda_r, 2 * np.pi / lambda_s)
    expected -= expected.mean()
    expected /= np.sqrt(np.mean(expected**2))
    np.testing.assert_allclose(t.heights, expected, rtol=0, atol=1e-12)


def test_fourier_spectrum_is_zero_above_the_short_cutoff_and_flat_below_rolloff():
    """Periodogram |FFT h|² of periodic surfaces, |k| = q L / 2π. Above q_s it is rounding noise
    (< 1e-25 of the peak). Below q_r it is flat: the band means over 2 < |k| < 7 and 8 < |k| < 15
    (about 65 and 250 independent modes x 8 seeds, relative standard errors below 5 %) agree within
    15 %. Above q_r it is the power law: bands an octave apart differ by 2^(2(1+H)) (within 15 %)."""
    n, hurst = 256, 0.8
    lambda_r, lambda_s = 16.0, 4.0
    power = sum(np.abs(np.fft.fft2(fourier_surface(n, 1.0, hurst=hurst, rms_height=1.0, rolloff_wavelength=lambda_r,
                                                   short_cutoff_wavelength=lambda_s, seed=k).heights)) ** 2
                for k in range(8))
    kx = np.fft.fftfreq(n) * n
    k = np.hypot(kx[:, None], kx[None, :])
    assert power[k > n / lambda_s * 1.001].max() < 1e-25 * power.max()

    def band(k_lo, k_hi):
        return power[(k > k_lo) & (k < k_hi)].mean()

    assert band(2, 7) / band(8, 15) == pytest.approx(1.0, abs=0.15)
    assert band(20, 28) / band(40, 56) == pytest.approx(2 ** (2 * (1 + hurst)), rel=0.15)


def test_fourier_rms_normalisation_is_exact():
    t = fourier_surface((128, 96), 1e-6, fractal_dimension=2.3, rms_height=2e-7, seed=1)
    assert rms_height(t) == pytest.approx(2e-7, rel=1e-12)
    assert abs(t.heights.mean()) < 1e-12 * 2e-7
    t = fourier_surface((128, 96), 1e-6, fractal_dimension=2.3, rms_slope=0.15, seed=1, periodic=False)
    assert rms_slope(t) == pytest.approx(0.15, rel=1e-12)


def test_fourier_periodic_surface_wraps_and_nonperiodic_does_not():
    """The rms step across the wrap-around edge is that of the interior for a periodic surface
    (ratio within 0.7-1.4 for 256 edge pairs), and several times larger when cut from a larger one
    (H = 0.8: long wavelengths dominate, edges 256 nodes apart are decorrelated)."""
    def edge_ratio(t):
        h = t.heights
        wrap = np.sqrt(np.mean((h[0] - h[-1]) ** 2))
        inner = np.sqrt(np.mean(np.diff(h, axis=0) ** 2))
        return wrap / inner
    periodic = fourier_surface(256, hurst=0.8, rms_height=1.0, seed=4)
    cut = fourier_surface(256, hurst=0.8, rms_height=1.0, seed=4, periodic=False)
    assert 0.7 < edge_ratio(periodic) < 1.4
    assert edge_ratio(cut) > 5.0


@pytest.mark.parametrize("kwargs, parameter", [
    (dict(shape=0), "shape"), (dict(shape=(16, -4)), "shape"), (dict(shape=(16, 1)), "shape"),
    (dict(shape="big"), "shape"),
    (dict(spacing=0.0), "spacing"), (dict(spacing=-1.0), "spacing"),
    (dict(hurst=0.0), "hurst"), (dict(hurst=1.0), "hurst"), (dict(hurst=0.5, fractal_dimension=2.5), "hurst"),
    (dict(hurst=None), "hurst"),
    (dict(rms_height=None), "rms_height"), (dict(rms_height=-1.0), "rms_height"),
    (dict(short_cutoff_wavelength=1.0), "short_cutoff_wavelength"),
    (dict(short_cutoff_wavelength=0.0), "short_cutoff_wavelength"),
    (dict(rolloff_wavelength=4.0, short_cutoff_wavelength=8.0), "rolloff_wavelength"),
    (dict(rolloff_wavelength=-4.0), "rolloff_wavelength"),
    (dict(periodic="no"), "periodic"), (dict(seed=-3), "seed"),
])
def test_fourier_bad_arguments_name_the_parameter(kwargs, parameter):
    args = dict(shape=16, spacing=1.0, hurst=0.8, rms_height=1.0)
    args.update(kwargs)
    with pytest.raises(InputError) as err:
        fourier_surface(**args)
    assert err.value.parameter == parameter


# --------------------------------------------------------------------------- reproducibility


def _digest(topography) -> str:
    return hashlib.sha256(np.ascontiguousarray(topography.heights).tobytes()).hexdigest()


def test_same_seed_same_surface_different_seed_different_surface():
    for make in (lambda seed: midpoint_surface(6, 2.3, 1e-4, rms_height=1e-6, seed=seed, random_additions=True),
                 lambda seed: fourier_surface(64, 1e-4, hurst=0.7, rms_height=1e-6, seed=seed, periodic=False)):
        assert _digest(make(42)) == _digest(make(42))
        assert _digest(make(42)) != _digest(make(43))


def test_seed_gives_the_same_surface_on_every_rank():
    """Each rank generates independently (no communication); the bytes must agree on all ranks."""
    MPI = pytest.importorskip("mpi4py.MPI")
    comm = MPI.COMM_WORLD
    for topography in (midpoint_surface(7, 2.2, 1e-4, rms_height=1e-6, seed=9, random_additions=True),
                       fourier_surface((96, 80), 1e-4, fractal_dimension=2.2, rms_slope=0.1, seed=9,
                                       rolloff_wavelength=2e-3, periodic=False)):
        digests = comm.allgather(_digest(topography))
        assert len(set(digests)) == 1, digests
        assert topography.metadata["rng"].startswith("numpy PCG64")
