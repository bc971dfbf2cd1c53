"""rms height, rms slope, PSD, structure function, detrending, footprints: analytic references.

Known truths: a plane has rms slope sqrt(a² + b²) exactly under forward
differences and S(r) = a² r² along x; a sampled sinusoid of amplitude A and
wavelength λ = m s has Sq = A/√2 exactly and forward-difference slope
(2A/s) sin(π s/λ)/√2 exactly; Parseval ties the PSD to the mean square; a
least-squares plane fit removes a plane to rounding.
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.surfaces import (
    Topography,
    detrend,
    disc,
    fourier_surface,
    radial_psd,
    rectangle,
    rms_height,
    rms_slope,
    structure_function,
)


def plane(shape, spacing, a, b, c=0.0):
    x = np.arange(shape[0])[:, None] * spacing
    y = np.arange(shape[1])[None, :] * spacing
    return c + a * x + b * y + 0.0 * x * y


def test_rms_slope_of_a_plane_is_exact():
    t = Topography(plane((30, 20), 1e-3, 0.03, -0.04, 5e-3), 1e-3)
    assert rms_slope(t) == pytest.approx(0.05, rel=1e-12)


def test_rms_of_a_sampled_sinusoid_is_exact():
    """Whole periods along x: Sq = A/√2; forward differences of sin give (2A/s) sin(π s/λ) cos(...)."""
    s, amplitude, m = 2e-6, 3e-7, 16
    x = np.arange(4 * m) * s
    h = amplitude * np.sin(2 * np.pi * x / (m * s))
    t = Topography(np.repeat(h[:, None], 8, axis=1), s)
    assert rms_height(t) == pytest.approx(amplitude / np.sqrt(2), rel=1e-12)
    # forward differences over 4m - 1 pairs: not a whole number of periods, so compare to the pairs' own mean
    diffs = np.diff(h) / s
    assert rms_slope(t) == pytest.approx(np.sqrt(np.mean(diffs**2)), rel=1e-12)
    # and that is the analytic finite-difference slope within the one-pair truncation (1/(4m) relative)
    analytic = 2 * amplitude / s * np.sin(np.pi / m) / np.sqrt(2)
    assert rms_slope(t) == pytest.approx(analytic, rel=1.0 / (4 * m))


def test_statistics_use_only_the_footprint():
    """NaN and wild values off the footprint change nothing."""
    h = plane((20, 20), 1.0, 0.1, 0.2)
    footprint = np.zeros((20, 20), dtype=bool)
    footprint[5:15, 5:15] = True
    dirty = np.where(footprint, h, np.nan)
    dirty[0, 0] = np.nan
    t = Topography(dirty, 1.0, footprint)
    assert rms_slope(t) == pytest.approx(np.hypot(0.1, 0.2), rel=1e-12)
    inner = h[5:15, 5:15]
    assert rms_height(t) == pytest.approx(np.std(inner), rel=1e-12)


def test_parseval_without_window():
    """Σ counts · C · Δqx Δqy = <(h - <h>)²> to rounding (the transform keeps every mode, q > 0)."""
    t = fourier_surface((64, 48), 1e-6, hurst=0.6, rms_height=1e-7, seed=2)
    p = radial_psd(t, window=None)
    total = np.sum(p.counts * p.psd) * p.wavevector_spacing[0] * p.wavevector_spacing[1]
    assert total == pytest.approx(rms_height(t) ** 2, rel=1e-12)
    assert p.counts.sum() == 64 * 48 - 1


def test_psd_of_a_single_mode_sits_at_its_wavevector():
    """A cosine of wavelength λ = L/8 along x puts all its power, A²/2, in the bin of q = 2π/λ
    (the bin centre is the mean log |q| of its modes: within one bin width, 10^(1/20), of 2π/λ)."""
    n, s, amplitude = 64, 1.0, 2.0
    x = np.arange(n) * s
    t = Topography(np.repeat(amplitude * np.cos(2 * np.pi * x / (n * s / 8))[:, None], n, axis=1), s)
    p = radial_psd(t, window=None)
    peak = np.argmax(p.psd)
    assert abs(np.log10(p.wavevector[peak] / (2 * np.pi * 8 / (n * s)))) < 1 / 20
    power = p.counts * p.psd * p.wavevector_spacing[0] * p.wavevector_spacing[1]
    assert power[peak] == pytest.approx(amplitude**2 / 2, rel=1e-12)


def test_hann_window_keeps_the_mean_square_of_white_noise():
    """For white noise the windowed PSD integrates to <h²> within its sampling error (3 % for 128²)."""
    rng = np.random.default_rng(0)
    t = Topography(rng.standard_normal((128, 128)), 1.0)
    p = radial_psd(t, window="hann")
    total = np.sum(p.counts * p.psd) * p.wavevector_spacing[0] * p.wavevector_spacing[1]
    assert total == pytest.approx(rms_height(t) ** 2, rel=0.03)


def test_structure_function_of_a_plane():
    """h = a x: pairs along x give a² r², pairs along y give 0; pooled over a square grid, a² r² / 2
    weighted by the pair counts of each axis (equal on a square grid)."""
    a = 0.3
    t = Topography(plane((40, 40), 0.5, a, 0.0), 0.5)
    sf = structure_function(t, lags=[1, 2, 5, 10])
    np.testing.assert_allclose(sf.structure_function, a**2 * sf.distance**2 / 2, rtol=1e-12)
    np.testing.assert_allclose(sf.distance, [0.5, 1.0, 2.5, 5.0])


def test_detrend_removes_a_plane_exactly():
    h = plane((33, 21), 1e-4, 2e-3, -5e-3, 7e-6)
    rough = fourier_surface((33, 21), 1e-4, hurst=0.7, rms_height=1e-7, seed=1).heights
    t = detrend(Topography(h + rough, 1e-4), "plane")
    # the plane goes, whatever tilt the roughness itself has is also removed: compare to the fit of rough alone
    expected = detrend(Topography(rough, 1e-4), "plane").heights
    np.testing.assert_allclose(t.heights, expected, rtol=0, atol=1e-12 * np.abs(h).max())
    pure = detrend(Topography(h, 1e-4), "plane")
    assert np.abs(pure.heights).max() < 1e-12 * np.abs(h).max()
    assert pure.metadata["detrend"]["slope_x"] == pytest.approx(2e-3, rel=1e-9)
    assert pure.metadata["detrend"]["slope_y"] == pytest.approx(-5e-3, rel=1e-9)
    assert pure.metadata["detrend"]["offset"] == pytest.approx(7e-6, rel=1e-9)


def test_detrend_mean_over_footprint_only():
    h = np.arange(16.0).reshape(4, 4)
    footprint = np.zeros((4, 4), dtype=bool)
    footprint[:2] = True
    t = detrend(Topography(h, 1.0, footprint), "mean")
    assert t.heights[footprint].mean() == pytest.approx(0.0, abs=1e-15)
    assert t.metadata["detrend"]["offset"] == pytest.approx(h[:2].mean())
    with pytest.raises(InputError) as err:
        detrend(t, "quadratic")
    assert err.value.parameter == "mode"


def test_disc_footprint_area_approaches_pi_d2_over_4():
    """Node count times s² is the disc area within the perimeter band (π D s)."""
    s, diameter = 1e-3, 50e-3
    mask = disc((61, 61), s, diameter)
    assert mask.sum() * s**2 == pytest.approx(np.pi * diameter**2 / 4, abs=np.pi * diameter * s)
    assert rectangle((3, 5)).all() and rectangle((3, 5)).shape == (3, 5)


@pytest.mark.parametrize("call, parameter", [
    (lambda: disc((10, 10), 0.0, 1.0), "spacing"),
    (lambda: disc((10, 10), 1.0, -2.0), "diameter"),
    (lambda: disc((10, 10), 1.0, 1e-3, centre=(100.0, 100.0)), "diameter"),
    (lambda: rectangle((0, 4)), "shape"),
    (lambda: Topography(np.zeros((4, 4)), 0.0), "spacing"),
    (lambda: Topography(np.zeros((4, 4)), -1.0), "spacing"),
    (lambda: Topography(np.zeros((4, 4)), (1.0, 2.0)), "spacing"),
    (lambda: Topography(np.zeros(4), 1.0), "heights"),
    (lambda: Topography(np.array([[0.0, np.nan], [1.0, 2.0]]), 1.0), "heights"),
    (lambda: Topography(np.array([[0.0, np.inf], [1.0, 2.0]]), 1.0), "heights"),
    (lambda: radial_psd(Topography(np.zeros((4, 4)), 1.0), window="blackman"), "window"),
])
def test_bad_input_names_the_parameter(call, parameter):
    with pytest.raises(InputError) as err:
        call()
    assert err.value.parameter == parameter


def test_nan_outside_the_footprint_is_allowed():
    footprint = np.array([[True, False], [True, True]])
    t = Topography(np.array([[0.0, np.nan], [1.0, 2.0]]), 1.0, footprint)
    assert np.isnan(t.heights[0, 1]) and t.nominal_area == 3.0
