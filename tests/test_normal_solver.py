"""Normal solver: rank invariance, solver agreement, control modes, edge states, failures."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from roughcontact.errors import ConvergenceError, InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import ActiveSetSettings, ActiveSetSolver, NormalProblem, make_solver, solve_closures
from roughcontact.surfaces import Topography, midpoint_surface

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))


def rough(levels=5, dimension=2.3, seed=3):
    return midpoint_surface(levels, dimension, spacing=1e-4, rms_height=2e-5, seed=seed)


def closure_for_fraction(topo, fraction):
    """A closure that brings roughly ``fraction`` of the nodes into geometric overlap."""
    h = topo.heights[topo.footprint]
    return float(h.max() - np.quantile(h, 1.0 - fraction))


def solve(topo, comm, closure, method="ksp", **kwargs):
    problem = NormalProblem(topo, ROCK, comm)
    with ActiveSetSolver(problem, method, **kwargs) as solver:
        res = solver.solve_closure(closure)
    problem.destroy()
    return res


def test_same_answer_on_one_and_all_ranks(comm):
    """COMM_SELF (1 rank) and COMM_WORLD (all ranks) agree to 1e-10 relative.

    Under ``mpiexec -n 2`` this compares a 1-rank and a 2-rank solve; the only
    differences are the order of floating-point reductions (1e-15), amplified by
    the inner solves (rtol 1e-11), far below 1e-10.
    """
    topo = rough()
    closure = closure_for_fraction(topo, 0.3)
    one = solve(topo, MPI.COMM_SELF, closure)
    many = solve(topo, comm, closure)
    np.testing.assert_array_equal(one.contact, many.contact)
    scale = np.abs(one.force).max()
    np.testing.assert_allclose(many.force, one.force, rtol=0, atol=1e-10 * scale)
    assert many.load == pytest.approx(one.load, rel=1e-10)


def test_krylov_and_gauss_seidel_agree(comm):
    """The paper's Gauss–Seidel inner solver gives the same contact state (1e-8)."""
    topo = rough(levels=4)
    closure = closure_for_fraction(topo, 0.3)
    ksp = solve(topo, comm, closure)
    gs = solve(topo, comm, closure, method="gauss-seidel")
    np.testing.assert_array_equal(ksp.contact, gs.contact)
    np.testing.assert_allclose(gs.force, ksp.force, rtol=0, atol=1e-8 * np.abs(ksp.force).max())
    assert gs.outer_iterations >= 1 and gs.linear_iterations > 0


def test_contact_conditions_hold(comm):
    """Eqs. 7a/7b with p ≥ 0: zero gap on S, positive gap and zero force outside."""
    topo = rough()
    res = solve(topo, comm, closure_for_fraction(topo, 0.3))
    scale = np.ptp(topo.heights)
    assert np.all(res.force >= 0.0)
    assert np.all(res.force[~res.contact] == 0.0)
    assert np.all(res.gap[~res.contact] >= -1e-8 * scale)
    assert res.residual < 1e-8


def test_load_control_inverts_displacement_control(comm):
    """Imposing the load of a closure returns that closure (rotation fixed to zero)."""
    topo = rough()
    closure = closure_for_fraction(topo, 0.2)
    problem = NormalProblem(topo, ROCK, comm)
    with ActiveSetSolver(problem) as solver:
        by_closure = solver.solve_closure(closure)
    with ActiveSetSolver(problem) as solver:
        by_load = solver.solve_load(by_closure.load, rotation=(0.0, 0.0))
    problem.destroy()
    assert by_load.closure == pytest.approx(closure, rel=1e-8)
    np.testing.assert_array_equal(by_load.contact, by_closure.contact)


def test_closure_sweep_is_monotone_and_warm_started(comm):
    """Load and contact area grow with closure; each increment reuses the last set."""
    topo = rough()
    top = closure_for_fraction(topo, 0.4)
    problem = NormalProblem(topo, ROCK, comm)
    results = solve_closures(problem, np.linspace(top / 4, top, 4))
    problem.destroy()
    loads = [r.load for r in results]
    areas = [r.contact_area for r in results]
    assert all(np.diff(loads) > 0) and all(np.diff(areas) > 0)
    # cold start of the last closure for comparison: warm start needs fewer outer iterations
    cold = solve(topo, comm, top)
    assert results[-1].outer_iterations <= cold.outer_iterations
    np.testing.assert_allclose(results[-1].force, cold.force, rtol=0, atol=1e-9 * np.abs(cold.force).max())


def test_no_contact_is_a_valid_flagged_state(comm):
    topo = rough()
    res = solve(topo, comm, closure=-1e-6)
    assert res.no_contact and not res.full_contact
    assert res.load == 0.0 and res.contact_area == 0.0
    assert np.all(res.force == 0.0) and np.all(np.isfinite(res.force))
    assert np.all(res.gap[topo.footprint] > 0.0)


def test_zero_load_is_a_valid_flagged_state(comm):
    topo = rough()
    problem = NormalProblem(topo, ROCK, comm)
    with ActiveSetSolver(problem) as solver:
        res = solver.solve_load(0.0)
    problem.destroy()
    assert res.no_contact and res.load == 0.0 and np.all(np.isfinite(res.force))


def test_full_contact_is_a_valid_flagged_state(comm):
    topo = rough(levels=4)
    res = solve(topo, comm, closure=20.0 * np.ptp(topo.heights))
    assert res.full_contact and not res.no_contact
    assert np.all(res.force[topo.footprint] > 0.0) and np.all(np.isfinite(res.force))
    assert res.contact_fraction == 1.0


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, parameter", [
    (dict(E=0.0, nu=0.3), "E"),
    (dict(E=-1e9, nu=0.3), "E"),
    (dict(E=1e9, nu=0.6), "nu"),
    (dict(E=1e9, nu=-1.0), "nu"),
    (dict(E=float("nan"), nu=0.3), "E"),
])
def test_bad_material_names_parameter(kwargs, parameter):
    with pytest.raises(InputError) as info:
        Material(**kwargs)
    assert info.value.parameter == parameter


def test_nan_heights_rejected():
    h = np.zeros((8, 8))
    h[3, 4] = np.nan
    with pytest.raises(InputError) as info:
        Topography(h, 1e-6)
    assert info.value.parameter == "heights"
    # masked out of the footprint, the same NaN is fine
    fp = np.ones((8, 8), bool)
    fp[3, 4] = False
    assert Topography(h, 1e-6, fp).footprint.sum() == 63


def test_empty_footprint_rejected():
    with pytest.raises(InputError) as info:
        Topography(np.zeros((8, 8)), 1e-6, np.zeros((8, 8), bool))
    assert info.value.parameter == "footprint"


def test_non_square_and_non_uniform_grids_rejected():
    with pytest.raises(InputError) as info:
        Topography(np.zeros((8, 8)), (1e-6, 2e-6))
    assert info.value.parameter == "spacing"
    x = np.array([0.0, 1.0, 2.0, 3.5]) * 1e-6
    with pytest.raises(InputError) as info:
        Topography.from_coordinates(x, x[:3] * 0 + np.arange(3) * 1e-6, np.zeros((4, 3)))
    assert info.value.parameter == "x"
    with pytest.raises(InputError) as info:
        Topography.from_coordinates(np.arange(4) * 1e-6, np.arange(3) * 2e-6, np.zeros((4, 3)))
    assert info.value.parameter == "spacing"


def test_negative_load_and_outside_load_point_rejected(comm):
    topo = rough(levels=3)
    problem = NormalProblem(topo, ROCK, comm)
    with ActiveSetSolver(problem) as solver:
        with pytest.raises(InputError) as info:
            solver.solve_load(-1.0)
        assert info.value.parameter == "load"
        far = 10 * topo.shape[0] * topo.spacing
        with pytest.raises(InputError) as info:
            solver.solve_load(1.0, moments=(0.0, far))
        assert info.value.parameter == "moments"
        with pytest.raises(InputError) as info:
            solver.solve_closure(float("nan"))
        assert info.value.parameter == "closure"
    problem.destroy()


def test_unknown_method_rejected(comm):
    problem = NormalProblem(rough(levels=3), ROCK, comm)
    with pytest.raises(InputError) as info:
        ActiveSetSolver(problem, method="newton")
    assert info.value.parameter == "method"
    problem.destroy()


# ---------------------------------------------------------------- failures are loud
def test_krylov_divergence_raises_with_reason(comm):
    topo = rough()
    with pytest.raises(ConvergenceError) as info:
        solve(topo, comm, closure_for_fraction(topo, 0.3), options={"ksp_max_it": 2})
    # PETSc >= 3.24 names it DIVERGED_MAX_IT, older releases DIVERGED_ITS
    assert info.value.reason in ("KSP_DIVERGED_MAX_IT", "KSP_DIVERGED_ITS")


def test_active_set_iteration_limit_raises(comm):
    topo = rough()
    with pytest.raises(ConvergenceError) as info:
        solve(topo, comm, closure_for_fraction(topo, 0.3), settings=ActiveSetSettings(max_outer=1))
    assert info.value.reason == "ACTIVE_SET_MAX_ITERATIONS"


def test_options_database_selects_krylov_method(comm):
    """-normal_ksp_type through the options database changes the inner solver."""
    topo = rough(levels=4)
    closure = closure_for_fraction(topo, 0.3)
    cg = solve(topo, comm, closure)
    gmres = solve(topo, comm, closure, options={"ksp_type": "gmres"})
    assert "gmres" in gmres.solver and "cg" in cg.solver
    np.testing.assert_allclose(gmres.force, cg.force, rtol=0, atol=1e-8 * np.abs(cg.force).max())


@pytest.mark.parametrize("method", ["ksp", "gauss-seidel"])
def test_solver_needs_only_a_petsc_mat(comm, method):
    """Another Mat type (AIJ, same entries) gives the same state: the solvers use
    only the Mat interface (mult, createSubMatrix), not the dense storage."""
    topo = rough(levels=4)
    closure = closure_for_fraction(topo, 0.3)
    dense = solve(topo, comm, closure, method)
    reference = NormalProblem(topo, ROCK, comm)
    sparse_format = reference.operator.convert("aij")
    problem = NormalProblem(topo, ROCK, comm, operator=sparse_format)
    with ActiveSetSolver(problem, method) as solver:
        res = solver.solve_closure(closure)
    problem.destroy()
    sparse_format.destroy()
    reference.destroy()
    np.testing.assert_array_equal(res.contact, dense.contact)
    np.testing.assert_allclose(res.force, dense.force, rtol=0, atol=1e-9 * np.abs(dense.force).max())


def test_auto_method_on_a_user_mat_above_the_active_set_size(comm):
    """A user's Mat over more than 33² nodes: ``auto`` cannot take the CG (its Fourier
    preconditioner needs the kernel) and falls back to the active set, which reproduces
    the built-in operator's solution to the solver tolerance (1e-8 of the largest force)."""
    topo = rough(levels=6)                       # 65² = 4225 nodes
    closure = closure_for_fraction(topo, 0.1)
    reference = NormalProblem(topo, ROCK, comm, operator="dense")
    with make_solver(reference, "ksp") as solver:
        expected = solver.solve_closure(closure)
    user = reference.operator.convert("aij")
    problem = NormalProblem(topo, ROCK, comm, operator=user)
    with make_solver(problem) as solver:
        res = solver.solve_closure(closure)
    problem.destroy()
    user.destroy()
    reference.destroy()
    assert res.method == "ksp"
    np.testing.assert_array_equal(res.contact, expected.contact)
    np.testing.assert_allclose(res.force, expected.force, rtol=0, atol=1e-8 * np.abs(expected.force).max())


@pytest.mark.parametrize("seed", range(8))
def test_load_control_converges_on_rough_surfaces(comm, seed):
    """Free rotations, zero moments, cold starts on rough surfaces: the damped Newton
    iteration on (δz, θ) converges where updating the set and the motion together
    cycled (1 to 4 cases in 60 of these); equilibrium to load_tol = 1e-8 and the
    contact conditions to tol = 1e-8."""
    topo = midpoint_surface(4 + seed % 2, 2.3, spacing=1e-4, rms_height=2e-5, seed=seed)
    problem = NormalProblem(topo, ROCK, comm)
    extent = np.abs(np.argwhere(topo.footprint) * topo.spacing - problem.centroid).max()
    for load in (2.0, 60.0):
        with ActiveSetSolver(problem) as solver:
            res = solver.solve_load(load)
        assert res.load == pytest.approx(load, rel=1e-8)
        assert abs(res.moments[0]) <= 1e-8 * load * extent and abs(res.moments[1]) <= 1e-8 * load * extent
        assert res.residual <= 1e-8 and np.all(res.force >= 0.0)
        assert np.all(res.gap[topo.footprint & ~res.contact] >= -1e-8 * np.ptp(topo.heights))
    problem.destroy()


def test_load_control_iteration_limit_raises(comm):
    """One Newton step cannot reach equilibrium from a cold start: it says so."""
    topo = rough()
    problem = NormalProblem(topo, ROCK, comm)
    with ActiveSetSolver(problem, settings=ActiveSetSettings(max_newton=1)) as solver:
        with pytest.raises(ConvergenceError) as info:
            solver.solve_load(50.0)
    problem.destroy()
    assert info.value.reason == "LOAD_CONTROL_MAX_ITERATIONS"


def test_zero_load_with_fixed_rotation_is_at_first_touch(comm):
    """P = 0 with an imposed tilt: nothing may interpenetrate and one node just touches
    (the largest approach with all gaps >= 0), whatever the tilt does to the heights."""
    topo = rough()
    problem = NormalProblem(topo, ROCK, comm)
    tilt = 5.0 * np.ptp(topo.heights) / (topo.shape[0] * topo.spacing)   # tilt dominates roughness
    with ActiveSetSolver(problem) as solver:
        res = solver.solve_load(0.0, rotation=(0.0, tilt))
    problem.destroy()
    gaps = res.gap[topo.footprint]
    assert res.no_contact and res.load == 0.0
    assert gaps.min() == pytest.approx(0.0, abs=1e-15 * np.ptp(topo.heights))
    assert np.all(gaps >= -1e-15 * np.ptp(topo.heights))      # round-off of δz − θ y − gap0
