"""Fits with intervals, force statistics (§6, Fig. 13), ensembles, and what the analysis reads.

Fits are checked against the textbook least-squares formulas and against
synthetic samples drawn from known laws; the tolerance of each sampled case
is stated with the spread measured over 100 seeds.
"""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughcontact.analysis import (
    as_dataset,
    contact_dimension,
    ensemble_statistics,
    force_statistics,
    line_fit,
    map_samples,
    power_law_fit,
    standard_names,
)
from roughcontact.errors import InputError

T_975_3 = 3.182446305284263    # Student t, 97.5 % quantile, 3 degrees of freedom (tables)


def test_line_fit_matches_the_textbook_formulas():
    """slope = Sxy / Sxx, stderr = sqrt(RSS / (n − 2) / Sxx), R² = 1 − RSS / Syy, interval = ± t stderr."""
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    y = np.array([1.1, 2.9, 5.2, 6.8, 9.1])
    sxx = np.sum((x - x.mean()) ** 2)
    slope = np.sum((x - x.mean()) * (y - y.mean())) / sxx
    rss = np.sum((y - y.mean() - slope * (x - x.mean())) ** 2)
    fit = line_fit(x, y)
    assert fit.slope == pytest.approx(slope, rel=1e-12)
    assert fit.slope_stderr == pytest.approx(np.sqrt(rss / 3 / sxx), rel=1e-12)
    assert fit.r_squared == pytest.approx(1.0 - rss / np.sum((y - y.mean()) ** 2), rel=1e-12)
    assert fit.slope_interval[1] - fit.slope == pytest.approx(T_975_3 * np.sqrt(rss / 3 / sxx), rel=1e-9)


def test_power_law_fit_recovers_a_known_exponent():
    """y = 3 x^−1.7 with 2 % log-normal scatter on 12 points: exponent within its 95 % interval and 0.05."""
    rng = np.random.default_rng(2)
    x = np.geomspace(1.0, 100.0, 12)
    fit = power_law_fit(x, 3.0 * x**-1.7 * np.exp(0.02 * rng.standard_normal(12)))
    assert fit.slope_interval[0] < -1.7 < fit.slope_interval[1]
    assert fit.slope == pytest.approx(-1.7, abs=0.05)
    exact = power_law_fit(x, 3.0 * x**-1.7)
    assert (exact.slope, np.exp(exact.intercept), exact.r_squared) == pytest.approx((-1.7, 3.0, 1.0), rel=1e-12)


def test_fits_refuse_bad_input():
    with pytest.raises(InputError, match="at least 3"):
        line_fit([1.0, 2.0], [1.0, 2.0])
    with pytest.raises(InputError, match="one abscissa"):
        line_fit([1.0, 1.0, 1.0], [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="NaN"):
        line_fit([1.0, 2.0, 3.0], [1.0, np.nan, 3.0])
    with pytest.raises(InputError, match="positive"):
        power_law_fit([1.0, 2.0, 3.0], [1.0, 0.0, 3.0])


def test_semilog_law_of_an_exponential_population():
    """20 000 forces drawn from exp(−p̄ / 2 N): log N = a − p̄ / (2 N), slope −0.5 /N.

    Over 100 seeds the fitted slope had mean −0.493 (least squares on the log of Poisson counts is
    biased low in magnitude by ~1 %) and spread 0.011: tolerance 0.05. The cumulative distribution is
    the empirical one: 0 at p̄ = 0, 1 at the largest force.
    """
    rng = np.random.default_rng(0)
    forces = rng.exponential(2.0, 20000)
    ds = force_statistics(forces, np.ones(forces.size, dtype=bool))
    assert float(ds["force_semilog_slope"]) == pytest.approx(-0.5, abs=0.05)
    assert float(ds["force_semilog_slope_r2"]) > 0.99
    assert int(ds["force_count"].sum()) == 20000
    assert float(ds["force_cumulative"][0]) == 0.0 and float(ds["force_cumulative"][-1]) == 1.0
    edge = float(ds["force_edge_value"][6])
    assert float(ds["force_cumulative"][6]) == pytest.approx(np.mean(forces <= edge), abs=1e-12)
    assert float(ds["mean_force"]) == pytest.approx(forces.mean(), rel=1e-12)


def test_power_law_of_the_squared_forces():
    """p̄² drawn with density ∝ (p̄²)^−1.6 on [1, 10⁴] N²: β = −1.6. Over 100 seeds: mean −1.603, spread
    0.009, so tolerance 0.04. Forces off the contact set are ignored."""
    rng = np.random.default_rng(0)
    u = rng.random(20000)
    square = (1.0 - u * (1.0 - 1e4**-0.6)) ** (-1.0 / 0.6)
    forces = np.concatenate([np.sqrt(square), np.full(50, 1e6)])
    contact = np.concatenate([np.ones(20000, dtype=bool), np.zeros(50, dtype=bool)])
    ds = force_statistics(forces, contact)
    assert float(ds["square_force_exponent"]) == pytest.approx(-1.6, abs=0.04)
    assert int(ds["loaded_nodes"]) == 20000
    assert float(ds["square_force_low"]) >= 1.0 and float(ds["square_force_high"]) <= 1e4


def test_force_statistics_refuse_degenerate_sets():
    with pytest.raises(InputError, match="too few values"):
        force_statistics(np.ones(2), np.ones(2, dtype=bool))
    with pytest.raises(InputError, match="equal forces"):
        force_statistics(np.ones(10), np.ones(10, dtype=bool))
    with pytest.raises(InputError, match="force: must be finite"):
        force_statistics(np.array([1.0, -1.0, 2.0]), np.ones(3, dtype=bool))


def test_ensemble_statistics_mean_and_interval():
    """Values 1, 2, 3, 4 over four seeds: mean 2.5, interval ± t(0.975, 3) s / 2 with s² = 5/3; a NaN
    sample is left out of its variable's count; one sample gives no interval."""
    ds = xr.Dataset({"dimension": ("seed", [1.0, 2.0, 3.0, 4.0], {"units": "1", "long_name": "Δσ"}),
                     "gappy": ("seed", [1.0, np.nan, 3.0, 5.0]),
                     "dimension_stderr": ("seed", [0.1] * 4),
                     "constant": ((), 7.0)}, coords={"seed": [0, 1, 2, 3]})
    out = ensemble_statistics(ds, "seed")
    half = T_975_3 * np.sqrt(5.0 / 3.0) / 2.0
    assert float(out["dimension"]) == 2.5
    assert (float(out["dimension_lower"]), float(out["dimension_upper"])) == pytest.approx((2.5 - half, 2.5 + half))
    assert out["dimension"].attrs["cell_methods"] == "seed: mean"
    assert int(out["gappy_samples"]) == 3 and float(out["gappy"]) == 3.0
    assert "dimension_stderr" not in out and float(out["constant"]) == 7.0
    with pytest.raises(InputError, match="at least 2"):
        ensemble_statistics(ds.isel(seed=[0]), "seed")
    with pytest.raises(InputError, match="not a dimension"):
        ensemble_statistics(ds, "shift")


def test_map_samples_keeps_dimensions_and_their_coordinates():
    """A (fractal_dimension, normal_load, x, y) field: results on the two leading dims, the coordinates kept,
    each sample equal to the measure on that sample alone."""
    rng = np.random.default_rng(1)
    contact = rng.random((2, 3, 16, 16)) < 0.4
    da = xr.DataArray(contact, dims=("fractal_dimension", "normal_load", "x", "y"),
                      coords={"fractal_dimension": [2.1, 2.3], "normal_load": [1.0, 2.0, 4.0],
                              "step": ("normal_load", [0, 1, 2])})
    out = map_samples(lambda mask: xr.Dataset({"nodes": ((), int(mask.sum()))}), [da], ("x", "y"))
    assert out["nodes"].dims == ("fractal_dimension", "normal_load")
    np.testing.assert_array_equal(out["nodes"], contact.sum(axis=(2, 3)))
    np.testing.assert_array_equal(out["normal_load"], [1.0, 2.0, 4.0])
    np.testing.assert_array_equal(out["step"], [0, 1, 2])


def test_standard_names_and_result_inputs(comm):
    """A sweep written with ``load`` along ``step`` is read with ``normal_load`` as its dimension; a
    NormalResult's spacing comes back from A_0 = (footprint nodes) s²."""
    from roughcontact.datasets import normal_sweep_dataset
    from roughcontact.materials import Interface, Material
    from roughcontact.normal import NormalProblem, solve_loads
    from roughcontact.surfaces import midpoint_surface

    topography = midpoint_surface(4, 2.3, spacing=2e-4, rms_height=1e-5, seed=3)
    problem = NormalProblem(topography, Interface(Material(20e9, 0.2)), comm)
    try:
        results = solve_loads(problem, (5.0, 20.0, 80.0))
    finally:
        problem.destroy()
    one = as_dataset(results[1])
    assert one.attrs["spacing"] == pytest.approx(2e-4, rel=1e-12)
    assert float(one["normal_load"]) == pytest.approx(20.0, rel=1e-9)
    sweep = normal_sweep_dataset(results, 2e-4)
    if "load" in sweep:                          # the older name of the scalar
        assert "normal_load" in standard_names(sweep).dims
    renamed = standard_names(sweep.rename({"normal_load": "load"}) if "normal_load" in sweep else sweep)
    assert "normal_load" in renamed.dims and renamed.sizes["normal_load"] == 3
    by_results = contact_dimension(results, box_range=(1, 4))
    by_dataset = contact_dimension(renamed, box_range=(1, 4))
    np.testing.assert_array_equal(by_results["box_count"], by_dataset["box_count"])
    with pytest.raises(InputError, match="source"):
        as_dataset([1, 2, 3])
