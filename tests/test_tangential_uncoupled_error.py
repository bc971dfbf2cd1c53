"""Datasets carry the measured error of the uncoupled Cattaneo model (§4.1, Eqs. 15–16, 21–24).

References, none produced by the code under test:

- the discrete Cattaneo theorem is exact for β = γ = 0 (§4.1): the bound is 0;
- the table of measured values (``roughcontact/tangential/uncoupled_error_table.py``,
  written by ``tools/chart_uncoupled_error.py --table``): at a charted ν and
  Q/fP the attribute is that entry;
- a coupled solve (:mod:`roughcontact.tangential.coupled`) on a Hertz contact
  coarser than the charted one (a/s ≈ 13 against 27): the actual error of the
  uncoupled sweep lies below the stated bound; and δx's error is Mindlin's
  compliance factor, 1 − 1/(1 + γ/2) (Johnson 1985, §7.2), independently of
  the solvers.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import ActiveSetSolver, NormalProblem
from roughcontact.surfaces import Topography
from roughcontact.tangential import (
    UncoupledApproximationWarning,
    fretting_cycle,
    fretting_dataset,
    tangential_dataset,
    tangential_sweep,
)
from roughcontact.tangential import uncoupled_error_table as measured
from roughcontact.tangential.coupled import coupled_sweep
from roughcontact.tangential.uncoupled_error import OUTSIDE, uncoupled_error_bound

from conftest import sphere_heights

RADIUS, A0, FRICTION = 0.01, 50e-6, 0.5
CHARTED_RATIOS = np.arange(1, 10) / 10          # Q = k fP / 10, k = 1 … 9


def identical(nu: float) -> Interface:
    """Two identical bodies: β = 0, γ = ν / (1 − ν) (Eq. 4b)."""
    return Interface(Material(200e9, nu), Material(200e9, nu))


def hertz(comm, interface: Interface, n: int = 33):
    """A sphere pressed to a = A0, a/s = (n − 1)/2.4, as the chart script builds it."""
    s = A0 / ((n - 1) / 2.4)
    problem = NormalProblem(Topography(sphere_heights(n, s, RADIUS), s), interface, comm)
    with ActiveSetSolver(problem) as solver:
        normal = solver.solve_closure(A0**2 / RADIUS)
    return problem, normal


def quiet_sweep(problem, normal, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UncoupledApproximationWarning)
        return tangential_sweep(problem, normal, FRICTION, method="ksp", **kwargs)


def test_exact_model_carries_zero_bound(comm):
    """ν = 0 on both bodies: β = γ = 0, the theorem is exact, every bound is 0."""
    problem, normal = hertz(comm, identical(0.0), n=17)
    try:
        attrs = tangential_dataset(quiet_sweep(problem, normal, steps=10), fields=False).attrs
    finally:
        problem.destroy()
    assert attrs["cattaneo_model"] == "exact"
    for metric in measured.ERRORS:
        assert attrs[f"uncoupled_error_{metric}"] == 0.0, metric


def test_charted_nu_gives_the_table_entry():
    """At a charted γ and one charted Q/fP the bound is that entry; over a range, the largest."""
    for i, gamma in enumerate(measured.GAMMA[1:], start=1):
        for k, ratio in enumerate(measured.Q_OVER_FP):
            for metric, table in measured.ERRORS.items():
                assert uncoupled_error_bound(metric, gamma, 0.0, [ratio]) == table[i][k]
        assert uncoupled_error_bound("approach", gamma, 0.0, [0.0, *CHARTED_RATIOS]) == max(
            measured.ERRORS["approach"][i])
    # between charted values: the larger of the two bracketing entries (ν = 0.25 lies between 0.2 and 0.3)
    gamma = 0.25 / 0.75
    assert uncoupled_error_bound("frictional_energy", gamma, 0.0, [0.45]) == max(
        measured.ERRORS["frictional_energy"][i][k] for i in (2, 3) for k in (3, 4))


def test_outside_the_charted_range_says_so(comm):
    """β ≠ 0, γ beyond the chart, Q/fP below or above it, and load reversals are not charted."""
    assert uncoupled_error_bound("approach", 0.2, 0.1, [0.5]) == OUTSIDE           # β ≠ 0
    assert uncoupled_error_bound("approach", 1.5, 0.0, [0.5]) == OUTSIDE           # γ > 1 (ν > 0.5)
    assert uncoupled_error_bound("approach", 0.25, 0.0, [0.05, 0.5]) == OUTSIDE    # Q/fP < 0.1
    assert uncoupled_error_bound("approach", 0.25, 0.0, [0.5, 0.95]) == OUTSIDE    # Q/fP > 0.9
    with pytest.raises(InputError, match="metric"):
        uncoupled_error_bound("stiffness", 0.25, 0.0, [0.5])
    # a rigid flat under an elastic body: β = (1 − 2ν)/(2(1 − ν)) ≠ 0 (Eq. 5)
    problem, normal = hertz(comm, Interface(Material(200e9, 0.3), Material.rigid()), n=17)
    try:
        sweep = quiet_sweep(problem, normal, steps=10)
        cycle = fretting_cycle(problem, normal, FRICTION, 0.5 * FRICTION * normal.load, 4, method="ksp")
    finally:
        problem.destroy()
    assert tangential_dataset(sweep, fields=False).attrs["uncoupled_error_approach"] == OUTSIDE
    # reversals (the fretting cycle) are outside the chart whatever the materials
    assert fretting_dataset(cycle).attrs["uncoupled_error_frictional_energy"] == OUTSIDE


def test_bound_holds_against_a_coupled_solve(comm):
    """ν = 0.3: the uncoupled sweep's actual errors lie below the dataset's stated bounds.

    Margins: 0.01 absolute on the relative errors of δx and E_f and on q_⊥/(f max p):
    the charted grid resolves the contact twice as finely (a/s ≈ 27 against 13), and
    the Hertz δx error is Mindlin's factor to within 0.3 % at a/s = 27
    (docs/tangential.md), so halving a/s moves it by well under 1 %.
    """
    nu = 0.3
    problem, normal = hertz(comm, identical(nu))
    try:
        uncoupled = quiet_sweep(problem, normal, steps=10, include_limit=False)
        coupled = coupled_sweep(problem, normal, FRICTION, steps=10)
    finally:
        problem.destroy()
    attrs = tangential_dataset(uncoupled, fields=False).attrs
    assert attrs["cattaneo_model"] == "uncoupled approximation"
    gamma = nu / (1 - nu)
    assert attrs["composite_poisson_gamma"] == pytest.approx(gamma, rel=1e-12)
    margin = 0.01
    approach, energy, cross = [], [], []
    for u, c in zip(uncoupled.states[1:], coupled.states[1:]):
        approach.append(abs(u.tangential_approach / c.tangential_approach - 1.0))
        energy.append(abs(u.frictional_energy / c.frictional_energy - 1.0))
        cross.append(float(np.abs(c.cross_traction).max() / (FRICTION * normal.force.max())))
    assert max(approach) <= attrs["uncoupled_error_approach"] + margin, (approach, attrs)
    assert max(energy) <= attrs["uncoupled_error_frictional_energy"] + margin, (energy, attrs)
    assert max(cross) <= attrs["uncoupled_error_cross_traction"] + margin, (cross, attrs)
    # and the error is Mindlin's: δx_uncoupled / δx_coupled = 1 / (1 + γ/2) (same margin)
    mindlin = 1.0 - 1.0 / (1.0 + gamma / 2.0)
    assert all(math.isclose(e, mindlin, abs_tol=margin) for e in approach), (approach, mindlin)
