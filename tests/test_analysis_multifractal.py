"""The Chhabra–Jensen spectrum (§6, Eqs. 28–31) against multiplicative cascades known in closed form.

A deterministic cascade of weights w_i (summing to 1) split over b^d children
per level has, at every box size of the cascade (Halsey et al., Phys. Rev. A
33, 1141, 1986; Chhabra & Jensen 1989):

    τ(q) = −log_b Σ w_i^q,   α(q) = −Σ w_i^q ln w_i / (Σ w_i^q ln b),   f = q α − τ.

The box sums at every size are themselves the cascade one level up, so the
direct method's sums are exactly linear in log ε and the fit reproduces the
closed form to round-off: tolerance 1e-9 over q ∈ [−10, 10] (the sums
involve w^q up to 0.1^−10 = 1e10 relative spreads, handled in logarithms).
"""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughcontact.analysis import box_counting, force_spectrum, multifractal_spectrum
from roughcontact.errors import InputError

Q = np.linspace(-10.0, 10.0, 41)


def cascade_1d(p: float, levels: int) -> np.ndarray:
    """Binomial cascade on 2^levels cells: each cell gives p to its left half and 1 − p to its right."""
    mass = np.ones(1)
    for _ in range(levels):
        mass = np.stack([p * mass, (1.0 - p) * mass], axis=1).ravel()
    return mass


def cascade_2d(weights, levels: int) -> np.ndarray:
    """Four weights on a 2 × 2 split, repeated: a 2^levels square."""
    mass = np.ones((1, 1))
    for _ in range(levels):
        mass = np.kron(mass, np.reshape(weights, (2, 2)))
    return mass


def closed_form(weights, q=Q):
    """τ(q), α(q), f(q) of a cascade with these weights on a 2-adic split."""
    w = np.ravel(weights)[None, :]
    moments = (w ** q[:, None]).sum(axis=1)
    tau = -np.log2(moments)
    alpha = -(w ** q[:, None] * np.log(w)).sum(axis=1) / (moments * np.log(2.0))
    return tau, alpha, q * alpha - tau


@pytest.mark.parametrize("measure, weights", [(cascade_1d(0.3, 12), (0.3, 0.7)),
                                              (cascade_2d((0.1, 0.2, 0.3, 0.4), 8), (0.1, 0.2, 0.3, 0.4))],
                         ids=["binomial 1-D", "four weights 2-D"])
def test_cascades_match_the_closed_form(measure, weights):
    ds = multifractal_spectrum(measure, q=Q)
    tau, alpha, f = closed_form(weights)
    np.testing.assert_allclose(ds["mass_exponent"], tau, atol=1e-9)
    np.testing.assert_allclose(ds["holder_exponent"], alpha, atol=1e-9)
    np.testing.assert_allclose(ds["singularity_spectrum"], f, atol=1e-9)
    dimension = np.ndim(measure)
    # D_0 = dimension of the support; D_1 = information dimension −Σ w log2 w; D_q decreases with q
    d = ds["generalised_dimension"]
    assert float(d.sel(q=0.0)) == pytest.approx(dimension, abs=1e-9)
    assert float(d.sel(q=1.0)) == pytest.approx(-np.sum(np.multiply(weights, np.log2(weights))), abs=1e-9)
    assert np.all(np.diff(d.values) < 0)
    # the maximum of f is the support's box-counting dimension, at q = 0
    assert float(ds["spectrum_maximum"]) == pytest.approx(dimension, abs=1e-9)
    assert float(ds["maximum_excess"]) == pytest.approx(0.0, abs=1e-9)
    assert float(ds["spectrum_width"]) == pytest.approx(alpha.max() - alpha.min(), abs=1e-9)


def test_uniform_measure_is_a_single_point():
    """Equal masses on a filled square: α = f = D_q = 2 for every q, width 0."""
    ds = multifractal_spectrum(np.full((64, 64), 0.5), q=Q)
    for name in ("holder_exponent", "singularity_spectrum", "generalised_dimension"):
        np.testing.assert_allclose(ds[name], 2.0, atol=1e-12)
    assert float(ds["spectrum_width"]) == pytest.approx(0.0, abs=1e-12)


def test_maximum_is_the_box_counting_dimension_of_the_support():
    """f(0) = D_0: at q = 0 the escort measure is uniform over the occupied boxes, so f(0) is minus the
    slope of log N(ε): the box-counting Δσ of the support over the same boxes (an identity, to 1e-12)."""
    rng = np.random.default_rng(3)
    support = rng.random((64, 64)) < 0.2
    measure = np.where(support, rng.exponential(1.0, (64, 64)), 0.0)
    ds = multifractal_spectrum(measure, q=Q)
    counted = float(box_counting(support)["contact_dimension"])
    assert float(ds["singularity_spectrum"].sel(q=0.0)) == pytest.approx(counted, abs=1e-12)
    assert float(ds["support_dimension"]) == pytest.approx(counted, abs=1e-12)


def test_force_spectrum_keeps_the_sample_dimensions():
    """Forces off the contact set are ignored; fields on (seed, normal_load, x, y) give spectra on
    (seed, normal_load, q), each the spectrum of that sample alone."""
    rng = np.random.default_rng(5)
    force = rng.exponential(1.0, (2, 3, 32, 32))
    contact = (rng.random((2, 3, 32, 32)) < 0.5).astype(np.int8)
    ds = xr.Dataset({"force": (("seed", "normal_load", "x", "y"), force),
                     "contact": (("seed", "normal_load", "x", "y"), contact)},
                    coords={"seed": [1, 2], "normal_load": [1.0, 2.0, 3.0]}, attrs={"spacing": 1e-4})
    spectra = force_spectrum(ds)
    assert spectra["holder_exponent"].dims == ("seed", "normal_load", "q")
    one = multifractal_spectrum(np.where(contact[1, 2] == 1, force[1, 2], 0.0), spacing=1e-4)
    np.testing.assert_allclose(spectra["holder_exponent"].sel(seed=2, normal_load=3.0), one["holder_exponent"],
                               rtol=1e-12)


def test_bad_input():
    with pytest.raises(InputError, match="measure: is zero"):
        multifractal_spectrum(np.zeros((32, 32)))
    with pytest.raises(InputError, match="measure: must be finite and >= 0"):
        multifractal_spectrum(-np.ones((32, 32)))
    with pytest.raises(InputError, match="q: holds a moment twice"):
        multifractal_spectrum(np.ones((32, 32)), q=[0.0, 1.0, 1.0])
    with pytest.raises(InputError, match="q: must be a non-empty list of finite moments"):
        multifractal_spectrum(np.ones((32, 32)), q=[np.nan])
    with pytest.raises(InputError, match="box_range"):
        multifractal_spectrum(np.ones((32, 32)), box_range=(1, 64))


def test_single_loaded_node_is_defined():
    """One node carries all the force: every box holding it has P = 1, so τ = α = f = 0 for every q."""
    measure = np.zeros((32, 32))
    measure[3, 4] = 7.0
    ds = multifractal_spectrum(measure, q=Q)
    for name in ("mass_exponent", "holder_exponent", "singularity_spectrum"):
        np.testing.assert_allclose(ds[name], 0.0, atol=1e-12)
