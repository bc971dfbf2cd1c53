"""Closure curves (§3.3–3.4, Figs. 5c, 8a): the bulk displacement removed exactly, the hyperbola fitted.

The bulk part is the displacement of the footprint under uniform pressure,
computed through the problem's operator. For a disc it converges to
Johnson's closed form for a uniformly loaded circle of radius a (Contact
Mechanics, 1985, §3.2, Eqs. 3.31–3.33): with A = 2/E* (paper, footnote 2)
the approach of the two surfaces is p a A at the centre and 16 p a /(3π E*)
= 8 p a A /(3π) on average.
"""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughcontact.analysis import closure_curve, hyperbola, hyperbola_fit
from roughcontact.analysis.petsc import bulk_compliance, footprint_bulk_compliance
from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import NormalProblem
from roughcontact.surfaces import Topography, disc

INTERFACE = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
TRUE = {"maximum_closure": 20e-6, "initial_stiffness": 5e6, "first_touch_closure": 3e-6}
LOADS = np.linspace(0.0, 500.0, 20)


def test_uniform_disc_matches_johnson_as_the_grid_is_refined(comm):
    """Discs of 16, 32 and 64 spacings across a 1 mm diameter, loaded by P/N on each of their N nodes.

    The pressure P / (N s²) acts on N s², so the circle compared is the one of equal area,
    a = s √(N/π). Measured relative errors of the mean and centre displacement: 0.94 %, 0.44 %,
    0.22 % and 0.79 %, 0.37 %, 0.18 %: first order in s. Asserted: every error below 1 %, and
    halving s divides it by at least 1.8 (first-order convergence; 2 in the limit).
    """
    errors = []
    for across in (16, 32, 64):
        spacing = 1e-3 / across
        footprint = disc((across + 1, across + 1), spacing, 1e-3)
        problem = NormalProblem(Topography(np.zeros(footprint.shape), spacing, footprint), INTERFACE, comm)
        try:
            bulk = bulk_compliance(problem)
        finally:
            problem.destroy()
        nodes = int(footprint.sum())
        radius = spacing * np.sqrt(nodes / np.pi)
        pressure = 1.0 / (nodes * spacing**2)               # unit total load
        centre = pressure * radius * INTERFACE.compliance
        mean = 8.0 * pressure * radius * INTERFACE.compliance / (3.0 * np.pi)
        errors.append((abs(bulk.mean / mean - 1.0), abs(bulk.centre / centre - 1.0)))
        assert np.nanmean(bulk.displacement) == pytest.approx(bulk.mean, rel=1e-12)
    errors = np.array(errors)
    assert np.all(errors < 0.01), errors
    assert np.all(errors[:-1] / errors[1:] > 1.8), errors


def test_hyperbola_with_noise_is_recovered():
    """20 loads, Gaussian noise of 1 % of δ_max on δ_eff. Over 200 noise seeds the standardised errors
    (estimate − truth) / stderr had a spread of 1.05–1.13 and never exceeded 3.8, so each parameter is
    asserted within 4 standard errors and the standard errors below 5 % of the values (an informative fit).
    """
    rng = np.random.default_rng(0)
    closure = hyperbola(LOADS, *TRUE.values()) + 0.01 * TRUE["maximum_closure"] * rng.standard_normal(LOADS.size)
    ds = hyperbola_fit(LOADS, closure)
    for name, truth in TRUE.items():
        assert abs(float(ds[name]) - truth) < 4.0 * float(ds[f"{name}_stderr"]), name
        assert float(ds[f"{name}_lower"]) < truth < float(ds[f"{name}_upper"]), name
    assert float(ds["maximum_closure_stderr"]) < 0.05 * TRUE["maximum_closure"]
    assert float(ds["initial_stiffness_stderr"]) < 0.05 * TRUE["initial_stiffness"]


def test_exact_hyperbola_through_the_origin():
    """No noise, δ0 fixed at 0: both parameters to 1e-9 (the optimiser's tolerance)."""
    ds = hyperbola_fit(LOADS, hyperbola(LOADS, 20e-6, 5e6), offset=False)
    assert float(ds["maximum_closure"]) == pytest.approx(20e-6, rel=1e-9)
    assert float(ds["initial_stiffness"]) == pytest.approx(5e6, rel=1e-9)
    assert float(ds["first_touch_closure"]) == 0.0


def test_straight_or_short_curves_are_refused():
    rng = np.random.default_rng(1)
    with pytest.raises(InputError, match="straight line"):
        hyperbola_fit(LOADS, 1e-8 * LOADS)
    with pytest.raises(InputError, match="no better than a straight line"):
        hyperbola_fit(LOADS, 1e-8 * LOADS * (1.0 + 0.01 * rng.standard_normal(LOADS.size)))
    with pytest.raises(InputError, match="need at least 4"):
        hyperbola_fit([0.0, 1.0, 2.0, 3.0], [0.0, 1e-6, 1.5e-6, 1.8e-6])


def test_closure_curve_removes_the_bulk_part(comm):
    """δz = c P + hyperbola on two seeds, with c the bulk compliance of a 17² square footprint: the
    effective closure is the hyperbola to round-off and its parameters come back to 1e-6."""
    footprint = np.ones((17, 17), dtype=bool)
    bulk = footprint_bulk_compliance(footprint, 1e-4, INTERFACE, comm)
    assert bulk.centre > bulk.mean > 0          # a uniformly loaded patch sinks most at its centre
    loads = LOADS[1:]
    curves = np.stack([hyperbola(loads, 20e-6, 5e6, 3e-6), hyperbola(loads, 10e-6, 8e6, 1e-6)])
    ds = xr.Dataset({"closure": (("seed", "normal_load"), curves + bulk.mean * loads)},
                    coords={"seed": [1, 2], "normal_load": ("normal_load", loads, {"units": "N"})})
    fit = closure_curve(ds, bulk.mean)
    np.testing.assert_allclose(fit["effective_closure"], curves, rtol=1e-9)
    np.testing.assert_allclose(fit["maximum_closure"], [20e-6, 10e-6], rtol=1e-6)
    np.testing.assert_allclose(fit["initial_stiffness"], [5e6, 8e6], rtol=1e-6)
    with pytest.raises(InputError, match="bulk_compliance"):
        closure_curve(ds, -1.0)
