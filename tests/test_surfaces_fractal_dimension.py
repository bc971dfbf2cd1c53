"""Fractal dimension estimators recover the Δ that generated a surface.

Bands (stated per estimator, from the sampling scatter and the known biases):
- PSD slope and variogram: |mean over 6 seeds − Δ| <= 0.1 on 513² (or 512²) surfaces for
  Δ = 2.2, 2.5, 2.8 and all generators. The seed-to-seed scatter of one estimate is 0.01–0.05,
  so the mean of 6 is within ±0.02 of its expectation; the remaining budget covers the fit-range
  bias (midpoint surfaces scale with a local H below the nominal one at the finest levels;
  periodic surfaces flatten the variogram at large lags).
- Cube counting underestimates Δ of rough surfaces (the height range of the (k+1)² nodes of a
  box grows faster than ε^H, see fractal_dimension_cube_counting): within ±0.1 at Δ = 2.2, and
  biased low by 0.05–0.35 at Δ = 2.5 and 2.8; it still increases with Δ.
- Smooth limits: a plane has S(r) ∝ r² exactly (variogram Δ = 2 to rounding), and its cube count
  N(ε) ∝ ε^-2 (Δ = 2 within 0.02, lattice alignment).
"""
from __future__ import annotations

import functools

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.surfaces import (
    Topography,
    fourier_surface,
    fractal_dimension,
    fractal_dimension_cube_counting,
    fractal_dimension_variogram,
    fractal_dimensions,
    midpoint_surface,
)

SEEDS = range(6)
GENERATORS = {
    "midpoint": lambda d, seed: midpoint_surface(9, d, 1e-5, rms_height=1e-6, seed=seed),
    "midpoint+additions": lambda d, seed: midpoint_surface(9, d, 1e-5, rms_height=1e-6, seed=seed,
                                                           random_additions=True),
    "fourier periodic": lambda d, seed: fourier_surface(512, 1e-5, fractal_dimension=d, rms_height=1e-6,
                                                        seed=seed),
    "fourier non-periodic": lambda d, seed: fourier_surface(513, 1e-5, fractal_dimension=d, rms_slope=0.1,
                                                            seed=seed, periodic=False),
}


@functools.lru_cache(maxsize=None)
def mean_estimates(generator: str, dimension: float) -> dict[str, float]:
    estimates = [fractal_dimensions(GENERATORS[generator](dimension, seed)) for seed in SEEDS]
    return {m: float(np.mean([e[m].fractal_dimension for e in estimates])) for m in estimates[0]}


@pytest.mark.parametrize("dimension", [2.2, 2.5, 2.8])
@pytest.mark.parametrize("generator", list(GENERATORS))
def test_psd_and_variogram_recover_the_generated_dimension(generator, dimension):
    found = mean_estimates(generator, dimension)
    assert found["psd"] == pytest.approx(dimension, abs=0.1), found
    assert found["variogram"] == pytest.approx(dimension, abs=0.1), found


@pytest.mark.parametrize("generator", list(GENERATORS))
def test_cube_counting_recovers_low_dimensions_and_underestimates_high_ones(generator):
    found = {d: mean_estimates(generator, d)["cube_counting"] for d in (2.2, 2.5, 2.8)}
    assert found[2.2] == pytest.approx(2.2, abs=0.1), found
    for d in (2.5, 2.8):
        assert d - 0.35 < found[d] < d - 0.05, found
    assert found[2.2] < found[2.5] < found[2.8]


def test_smooth_surface_has_dimension_two():
    x = np.arange(129)[:, None] * 1e-3
    y = np.arange(129)[None, :] * 1e-3
    t = Topography(0.37 * x + 0.21 * y, 1e-3)
    assert fractal_dimension_variogram(t).fractal_dimension == pytest.approx(2.0, abs=1e-9)
    assert fractal_dimension_cube_counting(t).fractal_dimension == pytest.approx(2.0, abs=0.02)


def test_estimate_reports_the_fitted_points():
    t = fourier_surface(128, 1e-6, hurst=0.5, rms_height=1e-7, seed=0)
    e = fractal_dimension(t, "variogram", scale_range=(2e-6, 20e-6))
    assert e.fitted.sum() >= 3
    assert e.scales[e.fitted].min() >= 2e-6 and e.scales[e.fitted].max() <= 20e-6 * (1 + 1e-9)
    assert e.hurst == pytest.approx(3.0 - e.fractal_dimension)


@pytest.mark.parametrize("kwargs, parameter", [
    (dict(method="box"), "method"),
    (dict(scale_range=(1e-6, 1.1e-6)), "scale_range"),
    (dict(scale_range=(2e-5, 1e-5)), "scale_range"),
    (dict(scale_range=(0.0, 1e-5)), "scale_range"),
    (dict(scale_range=5e-6), "scale_range"),
])
def test_bad_estimator_arguments_name_the_parameter(kwargs, parameter):
    t = fourier_surface(64, 1e-6, hurst=0.5, rms_height=1e-7, seed=0)
    with pytest.raises(InputError) as err:
        fractal_dimension(t, **kwargs)
    assert err.value.parameter == parameter


def test_flat_surface_has_no_cube_counting_dimension():
    with pytest.raises(InputError) as err:
        fractal_dimension_cube_counting(Topography(np.zeros((16, 16)), 1.0))
    assert err.value.parameter == "topography"
