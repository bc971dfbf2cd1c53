"""Cattaneo partial slip on the matrix-free path: corrective solves by the constrained CG.

Exactness (β = γ = 0): two bodies with ν = 0 (Eq. 4b, Eq. 5).
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.materials import Interface, Material
from roughcontact.normal import NormalProblem, make_solver
from roughcontact.surfaces import fourier_surface
from roughcontact.tangential import tangential_sweep

EXACT = Interface(Material(2.0, 0.0), Material(2.0, 0.0))      # E* = 1, β = γ = 0
FRICTION = 0.5


def surface(n: int):
    s = 1.0 / n
    return fourier_surface(n, s, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8 * s, periodic=False, seed=6)


def test_cg_corrective_solves_equal_the_active_set(comm):
    """A Q sweep with CG corrective solves gives the active set's stick sets and shear forces
    (1e-6 of the largest force: the CG's tolerance, see test_normal_cg)."""
    problem = NormalProblem(surface(96), EXACT, comm, operator="fft")
    with make_solver(problem, "cg") as solver:
        normal = solver.solve_load(0.01)
    sweeps = {m: tangential_sweep(problem, normal, FRICTION, steps=6, method=m, include_limit=False)
              for m in ("ksp", "cg")}
    scale = FRICTION * normal.force.max()
    for a, b in zip(sweeps["ksp"].states, sweeps["cg"].states):
        differ = a.stick != b.stick
        assert np.all(np.abs(a.traction[differ] - FRICTION * normal.force[differ]) <= 1e-6 * scale)
        np.testing.assert_allclose(b.traction, a.traction, rtol=0, atol=1e-6 * scale)
        assert b.tangential_approach == pytest.approx(a.tangential_approach, rel=1e-5)
    problem.destroy()


def test_tangential_sweep_on_a_512_grid(comm):
    """At 512² (a dense H would take 512 GiB): the sweep
    keeps Coulomb's inequalities, nests the stick sets, and its slip area grows linearly in Q
    as the paper finds (§5.1, Fig. 10): R² of a line through the sweep > 0.998 (measured 0.9999)."""
    problem = NormalProblem(surface(512), EXACT, comm, operator="fft")
    with make_solver(problem, "cg") as solver:
        normal = solver.solve_load(0.01)
    sweep = tangential_sweep(problem, normal, FRICTION, steps=8, method="cg", include_limit=False)
    assert sweep.resticking_nodes == 0
    ratios = np.array([st.load_ratio for st in sweep.states])
    slip = np.array([st.slip_area for st in sweep.states]) / normal.contact_area
    for earlier, later in zip(sweep.states, sweep.states[1:]):
        assert np.all(later.stick <= earlier.stick)
        assert later.coulomb_violation == 0.0
    fit = np.polyfit(ratios, slip, 1)
    residual = slip - np.polyval(fit, ratios)
    r2 = 1.0 - residual @ residual / np.sum((slip - slip.mean()) ** 2)
    assert r2 > 0.998
    problem.destroy()


def test_extrapolated_starts_give_the_fresh_solves(comm):
    """Each corrective solve of a sweep starts from the line through the last two (Eq. 23's
    p*(P*) is piecewise smooth); the states equal those of a fresh solver at each Q, started
    from the actual contact, to the CG's force tolerance (1e-6 of the largest force)."""
    from roughcontact.tangential import CattaneoSolver

    problem = NormalProblem(surface(96), EXACT, comm, operator="fft")
    with make_solver(problem, "cg") as solver:
        normal = solver.solve_load(0.01)
    sweep = tangential_sweep(problem, normal, FRICTION, steps=6, method="cg", include_limit=False)
    scale = FRICTION * normal.force.max()
    for state in sweep.states[2:]:
        with CattaneoSolver(problem, normal, FRICTION, method="cg") as fresh:
            alone = fresh.solve(state.tangential)
        differ = alone.stick != state.stick
        assert np.all(np.abs(alone.traction[differ] - FRICTION * normal.force[differ]) <= 1e-6 * scale)
        np.testing.assert_allclose(state.traction, alone.traction, rtol=0, atol=1e-6 * scale)
    problem.destroy()
