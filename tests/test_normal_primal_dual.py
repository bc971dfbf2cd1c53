"""The primal–dual active set near full contact (normal/primal_dual.py): the same state as the
paper's active set and the constrained CG, on any number of ranks, and a cycling set handed on.

Forces are compared at 1e-6 of the largest one, as in test_normal_cg.py: each solver meets the
contact conditions to tol = 1e-8 of the interpenetration's scale, and H's condition on the set
(O(10) with the Fourier preconditioner) turns that into about 1e-7 of the forces.
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import pytest
from mpi4py import MPI
from test_normal_cg import FLAT, assert_same_state, rough, solve

from roughcontact.errors import InputError
from roughcontact.normal import CGSettings, NormalProblem, make_solver, primal_dual

#: a mean pressure of E* closes 89 % of rough(160, 2)'s nodes; its coarse level's start (80², one
#: level below) holds 92 % (the punches' start on a grid without a coarse level holds far fewer:
#: 15 % of rough(160, 2)'s nodes at E*, 28 % of rough(64, 5)'s, whose solution closes 90 %)
NEAR_FULL = 1.0
#: every level whose start holds a quarter of its nodes in contact settles its set first, and every level
#: finds a free rotation with the forces
SETTLING = CGSettings(primal_dual_from=1, rotation_from=1)
WITHOUT = CGSettings(primal_dual_from=None, rotation_from=None)


def near_full_problem(comm, n: int = 160, seed: int = 2) -> NormalProblem:
    return NormalProblem(rough(n, seed), FLAT, comm, operator="fft")


def assert_contact_conditions(problem, result, load: float | None):
    """p ≥ 0, gap ≥ 0 off S and 0 on S to tol, Σ p = P: checked on H p of the result's own forces,
    not on anything the solver reports."""
    footprint = problem.topography.footprint
    forces = result.force[footprint]
    local = forces[problem.start:problem.stop]
    gap = problem.displacement(local) - problem.interpenetration(np.array([result.closure, *result.rotation]))
    contact = result.contact[footprint][problem.start:problem.stop]
    # the solver's measure: tol times the scale of the imposed w (the approach left out of it under
    # load control, where it is the multiplier), doubled for the round-off of the second product
    # that computes the gap here (about 1e-16 of its scale)
    imposed = np.array([0.0 if load is not None else result.closure, *result.rotation])
    bound = 2 * CGSettings().tol * problem.interpenetration_scale(problem.interpenetration(imposed))
    assert np.all(forces >= 0.0)
    assert np.all(gap[~contact] >= -bound) and np.all(np.abs(gap[contact]) <= bound)
    if load is not None:
        assert forces.sum() == pytest.approx(load, rel=1e-12)


def test_near_full_contact_settles_to_the_active_sets_state(comm):
    """Load control, rotation fixed: the same state as the paper's active set (KSP), the contact
    conditions met on the forces' own H p, and the sets counted (the CG alone reports one)."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0))    # noqa: E731
    reference = solve(problem, "ksp", control)
    result = solve(problem, "cg", control, settings=SETTLING)
    assert 0.85 < result.contact_fraction < 1.0                  # near full, with holes
    assert result.outer_iterations > 1 and result.residual <= 1e-8
    assert_same_state(reference, result)
    assert_contact_conditions(problem, result, NEAR_FULL)
    problem.destroy()


@pytest.mark.parametrize("rotation", [(0.0, 0.0), (0.05, -0.02)])
def test_displacement_control_settles_to_the_active_sets_state(comm, rotation):
    """Closure imposed (no multiplier, no load to restore), with and without an imposed rotation."""
    problem = near_full_problem(comm)
    closure = solve(problem, "ksp", lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0))).closure
    control = lambda s: s.solve_closure(closure, rotation=rotation)    # noqa: E731
    reference = solve(problem, "ksp", control)
    result = solve(problem, "cg", control, settings=SETTLING)
    assert result.outer_iterations > 1
    assert_same_state(reference, result)
    assert result.load == pytest.approx(reference.load, rel=1e-6)
    assert_contact_conditions(problem, result, None)
    problem.destroy()


@pytest.mark.parametrize("load, moments", [(NEAR_FULL, (0.0, 0.0)), (NEAR_FULL, (0.02, -0.01)),
                                           (0.01, (2e-4, -1e-4))])
def test_a_free_rotation_is_found_with_the_forces(comm, caplog, load, moments):
    """Load control with the rotation free, from a coarse level's start (zero moments, and the
    load point moved 0.01 and 0.02 off the centroid; near full contact and at 0.01 E*, a few per
    cent of the nodes): the primal–dual steps find (δz, θx, θy) with the forces, the moments two
    more constraints of each set's projected CG, and no Newton evaluation follows (every fine
    step is a primal–dual one). The state is the active set's, whose damped Newton on (δz, θx,
    θy) is another code, and so is the rotation, to 1e-6 as in test_normal_cg.py. The loads hold
    to round-off, Σ p = P and the moments to 1e-12 of P times the extent: the projection keeps
    C_Sᵀ p at the loads along every step (the sums of 25 600 forces round at about 1e-14)."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(load, moments=moments)    # noqa: E731
    reference = solve(problem, "ksp", control)
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        result = solve(problem, "cg", control, settings=SETTLING)
    steps = fine_steps(caplog, problem.size)
    assert steps and all("primal-dual" in step["restart"] for step in steps)
    assert result.outer_iterations > 1
    assert_same_state(reference, result)
    np.testing.assert_allclose(result.rotation, reference.rotation, rtol=1e-6)
    assert result.load == pytest.approx(load, rel=1e-12)
    np.testing.assert_allclose(result.moments, moments, rtol=0, atol=1e-12 * load * problem.extent)
    assert_contact_conditions(problem, result, load)
    problem.destroy()


def test_a_free_rotation_that_does_not_settle_goes_on_by_the_newton(comm, monkeypatch, caplog, settle_calls):
    """The rotation's primal–dual steps given up after one pass (MAX_SETS = 1), the fixed-rotation
    ones off (primal_dual_from=None, so that every marked step is theirs): the Newton on θ goes on
    from their forces (the trace: their steps, then the CG's), and reaches the active set's state,
    its moments within the Newton's load_tol of P times the extent. The fine level's count is the
    given-up steps' products plus the Newton's, each read where it is made."""
    from roughcontact.normal import constrained_cg

    problem = near_full_problem(comm)
    moments = (0.02, -0.01)
    control = lambda s: s.solve_load(NEAR_FULL, moments=moments)    # noqa: E731
    reference = solve(problem, "ksp", control)
    monkeypatch.setattr(primal_dual, "MAX_SETS", 1)
    counted = {}
    newton = constrained_cg.newton_on_motion

    def spying_newton(*args, **kwargs):
        state, rigid = newton(*args, **kwargs)
        counted["newton"] = state.linear                  # the last call is the fine level's
        return state, rigid

    monkeypatch.setattr(constrained_cg, "newton_on_motion", spying_newton)
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        handed = solve(problem, "cg", control, settings=CGSettings(primal_dual_from=None, rotation_from=1))
    marked = ["primal-dual" in step["restart"] for step in fine_steps(caplog, problem.size)]
    assert marked[0] and not marked[-1]
    assert marked == sorted(marked, reverse=True)        # the Newton's CG steps only after theirs
    rotation, settled = settle_calls[-1]
    assert rotation and not settled.converged and settled.products > 0
    assert handed.linear_iterations == settled.products + counted["newton"]
    assert_same_state(reference, handed)
    np.testing.assert_allclose(handed.rotation, reference.rotation, rtol=1e-6)
    bound = CGSettings().load_tol * NEAR_FULL * problem.extent
    np.testing.assert_allclose(handed.moments, moments, rtol=0, atol=bound)
    problem.destroy()


def test_a_set_that_cannot_hold_the_moments_is_left_to_the_newton(comm, monkeypatch, caplog):
    """Every set taken as one that cannot hold the moments (GRAM_CONDITION = 0, as for nodes on
    one line): the rotation's steps give up before their first step, and the solve is the
    Newton's, with no primal–dual step on the fine level and the active set's state."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(NEAR_FULL, moments=(0.02, -0.01))    # noqa: E731
    reference = solve(problem, "ksp", control)
    monkeypatch.setattr(primal_dual, "GRAM_CONDITION", 0.0)
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        left = solve(problem, "cg", control, settings=CGSettings(primal_dual_from=None, rotation_from=1))
    steps = fine_steps(caplog, problem.size)
    assert steps and not any("primal-dual" in step["restart"] for step in steps)
    assert_same_state(reference, left)
    np.testing.assert_allclose(left.rotation, reference.rotation, rtol=1e-6)
    problem.destroy()


def test_the_rigid_motions_fit_on_a_set(comm):
    """primal_dual._Motion with the moments imposed, on half the nodes of a grid (none of the last
    rank's on two ranks), against closed forms: the fit of a rigid field C_S r is r; a projected
    vector has C_Sᵀ v = 0; corrected forces hold the loads (Σ p, Σ p·(−y), Σ p·(−x)); one negative
    force on one rank fails the signs on every rank. To 1e-12
    (of the terms' count for C_Sᵀ v): sums of up to 3 200 terms of size 1 round at about 1e-14,
    and the 3 × 3 Gram matrix's condition (about 30 here) multiplies that."""
    problem = near_full_problem(comm, 80)
    rng = np.random.default_rng(comm.Get_rank())
    share = 0.0 if comm.Get_size() > 1 and comm.Get_rank() == comm.Get_size() - 1 else 0.5
    nodes = np.flatnonzero(rng.random(problem.local_size) < share)
    loads = np.array([1.0, 0.02, -0.01])
    motion = primal_dual._Motion(problem, loads[0], loads, problem.flexibility.workers)
    motion.on(nodes)
    x, y = problem.x[nodes], problem.y[nodes]
    r = np.array([0.3, -0.7, 1.1])
    rigid = r[0] - r[1] * y - r[2] * x
    np.testing.assert_allclose(motion.fit(rigid), r, rtol=1e-12)

    def transposed(v):
        return problem.allsum(np.array([v.sum(), -(v @ y), -(v @ x)]))

    v = rng.random(nodes.size)
    motion.project(v)
    np.testing.assert_allclose(transposed(v), 0.0, atol=1e-12 * float(problem.allsum(nodes.size)))
    forces = np.zeros(problem.local_size)
    forces[nodes] = rng.random(nodes.size)
    motion.rescale(forces)
    motion.correct(forces)
    np.testing.assert_allclose(transposed(forces[nodes]), loads, rtol=0, atol=1e-12)
    # a state is returned only with no negative force on S, the same answer on every rank
    forces[nodes] = np.abs(forces[nodes])
    assert motion.signs_hold(forces)
    if comm.Get_rank() == 0:
        forces[nodes[0]] = -1e-15
    assert not motion.signs_hold(forces)
    problem.destroy()


def test_a_set_on_one_line_cannot_hold_the_moments(comm):
    """_Motion.on: a set whose nodes lie on one grid row (C_S's columns 1 and −x dependent), a
    single node, and no node: False (the steps give up for the Newton on θ); a set on two rows:
    True."""
    problem = near_full_problem(comm, 32)
    motion = primal_dual._Motion(problem, 1.0, np.array([1.0, 0.0, 0.0]), problem.flexibility.workers)
    rows = problem.nodes[:, 0]                    # grid row index of each of this rank's nodes
    assert not motion.on(np.flatnonzero(rows == 0))         # the grid's first row (on the first rank)
    assert not motion.on(np.flatnonzero(rows == 0)[:1])
    assert not motion.on(np.zeros(0, dtype=np.intp))
    assert motion.on(np.flatnonzero(rows <= 1))
    problem.destroy()


@pytest.mark.parametrize("control", [lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0)),
                                     lambda s: s.solve_load(NEAR_FULL, moments=(0.02, -0.01))],
                         ids=["rotation fixed", "moments imposed"])
def test_the_same_state_on_one_and_all_ranks(comm, control):
    """COMM_SELF and COMM_WORLD: the same sets visited and the same state (the reductions differ
    in order only), and with the moments imposed the same rotation, to 1e-6 as against the active
    set (each meets the same tolerance)."""
    if comm.Get_size() == 1:
        pytest.skip("one rank: COMM_WORLD is COMM_SELF (the suite runs again on two)")
    results = []
    for c in (MPI.COMM_SELF, comm):
        problem = near_full_problem(c, 144, seed=5)
        results.append(solve(problem, "cg", control, settings=SETTLING))
        problem.destroy()
    assert results[0].outer_iterations == results[1].outer_iterations > 1
    assert_same_state(*results)
    np.testing.assert_allclose(results[1].rotation, results[0].rotation, rtol=1e-6, atol=1e-15)


def test_the_fine_level_settles_to_the_constrained_cgs_state(comm):
    """From the coarse level's start (the 80² level below is solved by the constrained CG, below
    ``primal_dual_from``): the state of the constrained CG alone."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0))    # noqa: E731
    alone = solve(problem, "cg", control, settings=WITHOUT)
    settled = solve(problem, "cg", control, settings=replace(SETTLING, primal_dual_from=problem.size))
    assert alone.outer_iterations == 1 and settled.outer_iterations > 1
    assert settled.coarse_iterations == alone.coarse_iterations > 0
    assert_same_state(alone, settled)
    problem.destroy()


def fine_steps(caplog, nodes: int) -> list[dict]:
    """The traced steps of the level of ``nodes`` nodes."""
    return [record.cg_step for record in caplog.records
            if hasattr(record, "cg_step") and record.cg_step["nodes"] == nodes]


@pytest.mark.parametrize("limit", ["MAX_SETS", "MAX_STEPS"])
def test_a_set_that_does_not_settle_is_handed_to_the_constrained_cg(comm, monkeypatch, caplog, limit):
    """Given up after one pass (MAX_SETS = 1) or one step on a set (MAX_STEPS = 1): the constrained
    CG goes on from its forces (the trace: primal–dual steps, then the CG's) and reaches the
    constrained CG's state alone."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0))    # noqa: E731
    alone = solve(problem, "cg", control, settings=WITHOUT)
    monkeypatch.setattr(primal_dual, limit, 1)
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        handed = solve(problem, "cg", control, settings=SETTLING)
    marked = ["primal-dual" in step["restart"] for step in fine_steps(caplog, problem.size)]
    assert marked and marked[0] and not marked[-1]
    assert marked == sorted(marked, reverse=True)        # the CG's steps only after the last settling one
    assert handed.outer_iterations == 1                  # the constrained CG's state
    assert_same_state(alone, handed)
    assert_contact_conditions(problem, handed, NEAR_FULL)
    problem.destroy()


def test_the_steps_take_at_most_max_iterations_products(comm):
    """One level (no coarse start), the rotation free, settled by the steps alone (with the
    rotation fixed the punches' start, 15 % of the nodes, is below ``primal_dual_share``, and the
    constrained CG takes it): its
    fine count is their products (each set's exact H p and each step's). Allowed exactly that
    many (``max_iterations``), the solve returns the same state; one fewer, it raises
    CG_MAX_ITERATIONS before the product that would pass the bound, on every rank at once (the
    count is the same on each)."""
    from roughcontact.errors import ConvergenceError

    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(NEAR_FULL)    # noqa: E731
    free = solve(problem, "cg", control, settings=SETTLING, nested=False)
    products = free.linear_iterations
    assert free.outer_iterations > 1 and products > free.outer_iterations   # the steps, on several sets
    bounded = solve(problem, "cg", control, nested=False,
                    settings=CGSettings(primal_dual_from=1, rotation_from=1, max_iterations=products))
    np.testing.assert_array_equal(bounded.force, free.force)
    with pytest.raises(ConvergenceError) as info:
        solve(problem, "cg", control, nested=False,
              settings=CGSettings(primal_dual_from=1, rotation_from=1, max_iterations=products - 1))
    assert info.value.reason == "CG_MAX_ITERATIONS" and "primal-dual" in str(info.value)
    problem.destroy()


@pytest.mark.parametrize("control", ["load", "closure"])
def test_a_warm_start_settles_its_set_too(comm, control):
    """The next load (or closure) of a sweep, started from the last solution (89 % in contact,
    above ``primal_dual_share``): the primal–dual steps, more than one set, and the paper's active
    set's state there."""
    problem = near_full_problem(comm)
    at = lambda load: lambda s: s.solve_load(load, rotation=(0.0, 0.0))    # noqa: E731
    if control == "closure":
        closures = [solve(problem, "ksp", at(load)).closure for load in (NEAR_FULL, 0.8 * NEAR_FULL)]
        first, second = (lambda s, c=c: s.solve_closure(c, rotation=(0.0, 0.0)) for c in closures)
    else:
        first, second = at(NEAR_FULL), at(0.8 * NEAR_FULL)
    with make_solver(problem, "cg", settings=SETTLING) as solver:
        first(solver)
        warm = second(solver)
    reference = solve(problem, "ksp", second)
    assert warm.coarse_iterations == 0 and warm.outer_iterations > 1
    assert_same_state(reference, warm)
    problem.destroy()


def test_the_share_in_contact_is_counted_at_the_start(comm):
    """``primal_dual_warm_share`` at the boundary: a warm start holding k of the N nodes in contact (the
    last solution's set) settles its set first where the share s gives s · N = k exactly (at least
    the share: ≥, not >), and is left to the constrained CG alone at the first float above s whose s · N passes k; the
    same state either way. The first load starts from the punches (no coarse level); both solvers'
    first states hold the k nodes of a first solve by the constrained CG alone (checked): the start
    of the warm solve."""
    problem = near_full_problem(comm)
    size = problem.size
    first = lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0))    # noqa: E731
    closed = int(np.count_nonzero(solve(problem, "cg", first, nested=False,
                                        settings=replace(SETTLING, primal_dual_share=1.0)).contact))
    assert 0.85 * size < closed < size
    # k / N · N need not give k back in floating point: the float next to k / N that does
    exact = [s for s in (np.nextafter(closed / size, 0.0), closed / size, np.nextafter(closed / size, 1.0))
             if float(s) * size == closed]
    assert exact
    above = np.nextafter(exact[0], 1.0)
    while float(above) * size <= closed:                # the first float whose s · N passes k
        above = np.nextafter(above, 1.0)
    states = []
    for share in (float(exact[0]), float(above)):
        # the warm start's share decides; the first, fresh start (15 % in contact) stays below both
        settings = replace(SETTLING, primal_dual_share=share, primal_dual_warm_share=share)
        with make_solver(problem, "cg", nested=False, settings=settings) as solver:
            start = first(solver)
            states.append(solver.solve_load(0.8 * NEAR_FULL, rotation=(0.0, 0.0)))
        assert np.count_nonzero(start.contact) == closed
    settled, alone = states
    assert settled.outer_iterations > 1 and alone.outer_iterations == 1
    assert_same_state(settled, alone)
    problem.destroy()


def test_a_warm_start_with_the_rotation_free_finds_it_with_the_forces(comm, caplog):
    """A second load on the same solver, the rotation free, starts from the first load's state
    (not fresh): the primal–dual steps still find the rotation with the forces (every fine step
    is one of theirs), and the state, rotation and moments are the active set's at that load, as
    from a fresh start (tolerances as in test_a_free_rotation_is_found_with_the_forces)."""
    problem = near_full_problem(comm)
    moments = (0.015, -0.008)
    reference = solve(problem, "ksp", lambda s: s.solve_load(0.8 * NEAR_FULL, moments=moments))
    with make_solver(problem, "cg", settings=SETTLING) as solver:
        solver.solve_load(NEAR_FULL, moments=moments)
        with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
            warm = solver.solve_load(0.8 * NEAR_FULL, moments=moments)
    steps = fine_steps(caplog, problem.size)
    assert steps and all("primal-dual" in step["restart"] for step in steps)
    assert warm.coarse_iterations == 0                       # no coarse level: a warm start
    assert_same_state(reference, warm)
    np.testing.assert_allclose(warm.rotation, reference.rotation, rtol=1e-6)
    np.testing.assert_allclose(warm.moments, moments, rtol=0, atol=1e-12 * NEAR_FULL * problem.extent)
    problem.destroy()


def test_a_sparse_start_takes_the_constrained_cg(comm):
    """A start with less than ``primal_dual_share`` of the nodes in contact (0.01 E*, a few per cent):
    the constrained CG alone, step for step."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(0.01, rotation=(0.0, 0.0))    # noqa: E731
    settled = solve(problem, "cg", control, settings=SETTLING)
    alone = solve(problem, "cg", control, settings=WITHOUT)
    assert settled.outer_iterations == 1
    assert settled.linear_iterations == alone.linear_iterations
    assert np.array_equal(settled.force, alone.force)
    problem.destroy()


def test_the_trace_names_the_primal_dual_steps(comm, caplog):
    """Traced at DEBUG: one record per step of the fine level, marked, a new set's first step
    marked as its restart; the same forces as untraced."""
    problem = near_full_problem(comm)
    control = lambda s: s.solve_load(NEAR_FULL, rotation=(0.0, 0.0))    # noqa: E731
    untraced = solve(problem, "cg", control, settings=SETTLING)
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        traced = solve(problem, "cg", control, settings=SETTLING)
    steps = fine_steps(caplog, problem.size)
    problem.destroy()
    assert np.array_equal(traced.force, untraced.force)
    assert steps and all(step["restart"][0] == "primal-dual" for step in steps)
    assert [step["iteration"] for step in steps] == list(range(1, len(steps) + 1))
    sets = sum("set" in step["restart"] for step in steps)
    assert 1 < sets <= traced.outer_iterations
    # the products: every step's, and the exact H p of each pass that did not go on on a held set
    assert len(steps) + sets <= traced.linear_iterations <= len(steps) + traced.outer_iterations


@pytest.mark.parametrize("name", ["primal_dual_from", "rotation_from"])
@pytest.mark.parametrize("value", [0, -1, 1.5, True, "all"])
def test_bad_primal_dual_levels_are_named(name, value):
    with pytest.raises(InputError, match=name):
        CGSettings(**{name: value})


@pytest.mark.parametrize("name", ["primal_dual_share", "primal_dual_warm_share"])
@pytest.mark.parametrize("value", [-0.1, 1.5, float("nan"), float("inf"), True, np.bool_(False), "half", None])
def test_a_bad_primal_dual_share_is_named(name, value):
    with pytest.raises(InputError, match=name):
        CGSettings(**{name: value})


@pytest.mark.parametrize("name", ["primal_dual_share", "primal_dual_warm_share"])
@pytest.mark.parametrize("value", [0, 1, 0.25, np.float64(0.5), np.float32(0.75), np.int64(1)])
def test_a_primal_dual_share_from_0_to_1_is_taken(name, value):
    assert getattr(CGSettings(**{name: value}), name) == value


def test_a_sparse_warm_start_settles_its_set_and_a_sparse_fresh_one_does_not(comm, caplog):
    """A light load's next load (a few per cent in contact, below the quarter of
    ``primal_dual_share``), started from the last solution: by default (``primal_dual_warm_share``
    0) the primal–dual steps take it, every fine step one of theirs; with the warm share at the
    quarter the constrained CG alone does, as it does the fresh first load either way. Both reach
    the paper's active set's state at that load."""
    problem = near_full_problem(comm)
    at = lambda load: lambda s: s.solve_load(load, rotation=(0.0, 0.0))    # noqa: E731
    reference = solve(problem, "ksp", at(0.012))
    states = {}
    for warm_share in (0.0, 0.25):
        with make_solver(problem, "cg", settings=replace(SETTLING, primal_dual_share=0.25,
                                                         primal_dual_warm_share=warm_share)) as solver:
            with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
                caplog.clear()
                fresh = solver.solve_load(0.01, rotation=(0.0, 0.0))
                fresh_steps = fine_steps(caplog, problem.size)
                caplog.clear()
                states[warm_share] = solver.solve_load(0.012, rotation=(0.0, 0.0))
                warm_steps = fine_steps(caplog, problem.size)
        assert np.count_nonzero(fresh.contact) < 0.25 * problem.size
        assert fresh_steps and not any("primal-dual" in step["restart"] for step in fresh_steps)
        assert states[warm_share].coarse_iterations == 0                     # a warm start
        settled = [step for step in warm_steps if "primal-dual" in step["restart"]]
        assert (settled == warm_steps and warm_steps) if warm_share == 0.0 else not settled
    for state in states.values():
        assert_same_state(reference, state)
    problem.destroy()

