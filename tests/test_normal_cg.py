"""Bound-constrained CG on the FFT operators: agreement with the active set, closed forms, failures.

The CG stops when the contact conditions hold to tol = 1e-8 of the scale of
the imposed interpenetration; the forces are then exact to about 1e-7 of the
largest one (the residual times the condition of H on the contact set, which
is O(10) with the Fourier preconditioner). Comparisons with the active-set
solver (exact to its inner rtol 1e-11) therefore use 1e-6 of the largest force.
"""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from roughcontact.collective import DestroyedError
from roughcontact.errors import ConvergenceError, InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import CGSettings, NormalProblem, make_solver
from roughcontact.references import hertz
from roughcontact.surfaces import Topography, disc, fourier_surface

from conftest import sphere_heights, table_block

FLAT = Interface(Material(1.0, 0.0))               # E* = 1 against a rigid flat
FORCE_RTOL = 1e-6


def rough(n: int = 64, seed: int = 1) -> Topography:
    s = 1.0 / n
    return fourier_surface(n, s, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8 * s, periodic=False, seed=seed)


def solve(problem, method, control, **options):
    with make_solver(problem, method, **options) as solver:
        return control(solver)


def assert_same_state(reference, result):
    """Same contact set except nodes the reference loads below the force tolerance; same forces."""
    scale = reference.force.max()
    differ = reference.contact != result.contact
    assert np.all(reference.force[differ] <= FORCE_RTOL * scale)
    np.testing.assert_allclose(result.force, reference.force, rtol=0, atol=FORCE_RTOL * scale)


CONTROL_MOMENTS = (2e-4, -1e-4)
CONTROLS = {
    "load, rotation fixed": lambda s: s.solve_load(0.01, rotation=(0.0, 0.0)),
    "load, rotation free": lambda s: s.solve_load(0.01),
    "load and moments": lambda s: s.solve_load(0.01, moments=CONTROL_MOMENTS),
    "closure": lambda s: s.solve_closure(0.08),
    "closure and rotation": lambda s: s.solve_closure(0.08, rotation=(0.05, -0.02)),
}


@pytest.mark.parametrize("control", sorted(CONTROLS))
@pytest.mark.parametrize("operator", ["fft", "dense"])
def test_cg_equals_active_set(comm, control, operator):
    """The same contact state as the active set (KSP) for every control, on both operators."""
    problem = NormalProblem(rough(), FLAT, comm, operator=operator)
    reference = solve(problem, "ksp", CONTROLS[control])
    result = solve(problem, "cg", CONTROLS[control])
    assert_same_state(reference, result)
    assert result.load == pytest.approx(reference.load, rel=1e-12 if "load" in control else 1e-6)
    if "moments" in control:
        # both meet the imposed moments to their load_tol of P times the footprint's half-size, the
        # stopping rule of each Newton on the rotation (a tighter bound held only where a last
        # exact Newton step happened to land far inside it)
        bound = CGSettings().load_tol * reference.load * problem.extent
        for state in (reference, result):
            np.testing.assert_allclose(state.moments, CONTROL_MOMENTS, rtol=0, atol=bound)
    else:
        np.testing.assert_allclose(result.moments, reference.moments, rtol=0, atol=1e-5 * reference.load)
    assert result.closure == pytest.approx(reference.closure, rel=1e-6)
    assert result.operator == operator and result.residual <= 1e-8
    problem.destroy()


def test_cg_same_answer_on_one_and_all_ranks(comm):
    """COMM_SELF and COMM_WORLD give the same state (reductions differ in order only)."""
    topo = rough(48, seed=4)
    results = []
    for c in (MPI.COMM_SELF, comm):
        problem = NormalProblem(topo, FLAT, c, operator="fft")
        results.append(solve(problem, "cg", CONTROLS["load, rotation free"]))
        problem.destroy()
    assert_same_state(*results)


def test_nested_start_gives_the_cold_answer(comm):
    """A coarse-to-fine start (grid > 128², so one coarse level) reaches the same state."""
    problem = NormalProblem(rough(160, seed=2), FLAT, comm, operator="fft")
    cold = solve(problem, "cg", CONTROLS["load, rotation fixed"], nested=False)
    nested = solve(problem, "cg", CONTROLS["load, rotation fixed"], nested=True)
    assert_same_state(cold, nested)
    assert nested.coarse_iterations > 0 and cold.coarse_iterations == 0
    problem.destroy()


def test_the_trace_follows_the_solve_and_leaves_it_unchanged(comm, caplog):
    """The CG's trace (its logger at DEBUG): the same forces and iterations as untraced (the trace
    only reads what the loop computes), one record per step of every level, the fine level's
    residuals those of the result's history at the same iterations, and a step only while the
    residual is above tol (the passes that confirm convergence take none)."""
    import logging

    problem = NormalProblem(rough(160, seed=2), FLAT, comm, operator="fft")   # one coarse level
    untraced = solve(problem, "cg", CONTROLS["load, rotation fixed"])
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        traced = solve(problem, "cg", CONTROLS["load, rotation fixed"])
    steps = [record.cg_step for record in caplog.records if hasattr(record, "cg_step")]
    nodes = problem.size
    problem.destroy()
    assert np.array_equal(traced.force, untraced.force)
    assert traced.linear_iterations == untraced.linear_iterations
    fine = [step for step in steps if step["nodes"] == nodes]
    coarse = [step for step in steps if step["nodes"] < nodes]
    assert coarse and fine and steps == coarse + fine                 # the level below first
    for level in (coarse, fine):
        assert level[0]["iteration"] == 1
        assert all(b["iteration"] > a["iteration"] for a, b in zip(level, level[1:]))
        assert level[0]["restart"] == ["start"] and level[0]["changed"] == level[0]["free"]
        assert all(step["alpha"] > 0.0 and step["free"] >= 1 for step in level)
    tol = CGSettings().tol
    history = traced.residual_history
    assert len(fine) < traced.linear_iterations == len(history)
    for step in fine:
        assert step["residual"] == history[step["iteration"] - 1] and step["residual"] > tol
    assert history[-1] <= tol


def test_returning_nodes_of_the_other_colour_are_held_back():
    """The rule of ``alternate_return`` on eight nodes, the expected set written out by hand: a
    node is taken out of the free set where it is free, out of contact, left earlier and on the
    square whose colour is not the iteration's parity."""
    from roughcontact.normal.constrained_cg import _hold_back

    free = np.array([1, 1, 1, 1, 1, 1, 0, 1], dtype=bool)
    contact = np.array([0, 0, 1, 0, 0, 1, 0, 0], dtype=bool)
    left = np.array([1, 1, 1, 0, 1, 1, 1, 1], dtype=bool)
    squares = np.array([0, 1, 0, 0, 1, 1, 0, 0], dtype=bool)
    # on an odd iteration the even squares wait: nodes 0 and 7 (node 2 is in contact, node 3 never
    # left, node 6 is not free); on an even one the odd squares: node 1 and 4 (node 5 in contact)
    for iteration, held in ((3, [0, 7]), (4, [1, 4])):
        mask = free.copy()
        count = _hold_back(mask, contact, left, squares, iteration, np.empty(8, dtype=bool))
        assert count == len(held)
        assert np.array_equal(np.flatnonzero(free & ~mask), held) and not np.any(mask & ~free)


@pytest.mark.parametrize("control", ["load, rotation fixed", "load, rotation free", "closure"])
def test_alternate_return_changes_the_path_not_the_state(comm, control, caplog):
    """Near full contact (89 % at 160², one coarse level) nodes that left the set come back on
    alternate iterations of the constrained CG (the trace's ``held``: none at the first step,
    when none has left yet, some later; with the rotation free the Newton's solves, which
    ``rotation_from=None`` forces); the state is the one reached without the rule, to the force
    tolerance."""
    import logging

    controls = {"load, rotation fixed": lambda s: s.solve_load(1.0, rotation=(0.0, 0.0)),
                "load, rotation free": lambda s: s.solve_load(1.0),
                "closure": lambda s: s.solve_closure(1.06)}
    problem = NormalProblem(rough(160, seed=2), FLAT, comm, operator="fft")
    without = solve(problem, "cg", controls[control], settings=CGSettings(alternate_return=False, rotation_from=None))
    with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
        alternating = solve(problem, "cg", controls[control], settings=CGSettings(rotation_from=None))
    held = [record.cg_step["held"] for record in caplog.records
            if hasattr(record, "cg_step") and record.cg_step["nodes"] == problem.size]
    problem.destroy()
    assert without.contact_fraction > 0.8
    assert held[0] == 0 and sum(held) > 0
    assert_same_state(without, alternating)
    assert alternating.residual <= CGSettings().tol


@pytest.mark.parametrize("deferring", [False, True], ids=["every cut settled", "far fields deferred"])
@pytest.mark.parametrize("footprint", ["square", "disc"])
@pytest.mark.parametrize("control", ["load, rotation fixed", "closure"])
def test_a_dense_free_set_takes_the_direction_field_whole(comm, control, footprint, deferring, monkeypatch):
    """Where the free set holds more than one node in DENSE_WRITE, the search direction's product
    is taken of the direction field itself (d on the set, zero elsewhere) instead of d scattered
    at the set's positions: the same field, so the same transforms. Near full contact (160², the
    whole grid or a disc's footprint, whose rows are partial) the solve is bit for bit the one
    that always scatters (``dense`` False in the CG), on any rank count; it fails if the field held anything
    off the set. The same with the far fields deferred (DEFER_FROM lowered to this grid)."""
    import roughcontact.normal.constrained_cg as constrained_cg

    if deferring:
        if footprint == "disc":
            pytest.skip("a footprint short of the whole grid has no near field: nothing is deferred")
        monkeypatch.setattr(constrained_cg, "DEFER_FROM", 0)
    controls = {"load, rotation fixed": lambda s: s.solve_load(0.8 if footprint == "disc" else 1.0,
                                                               rotation=(0.0, 0.0)),
                "closure": lambda s: s.solve_closure(1.06)}
    surface = rough(160, seed=2)
    if footprint == "disc":
        surface = Topography(surface.heights, surface.spacing, disc((160, 160), surface.spacing, 75 * surface.spacing))
    problem = NormalProblem(surface, FLAT, comm, operator="fft")
    whole = []
    product = NormalProblem.displacement

    def counted(self, forces, single=False):
        whole.append(forces.size)
        return product(self, forces, single)

    def counted_held(self, forces, single=False):
        whole.append(forces.size)
        return held(self, forces, single)

    held = NormalProblem.held_displacement
    monkeypatch.setattr(NormalProblem, "displacement", counted)
    monkeypatch.setattr(NormalProblem, "held_displacement", counted_held)
    dense = solve(problem, "cg", controls[control])
    taken = len(whole)
    monkeypatch.setattr(constrained_cg, "dense", lambda nodes, size: False)
    scattered = solve(problem, "cg", controls[control])
    problem.destroy()
    assert dense.contact_fraction > 0.8
    assert taken > len(whole) - taken + dense.linear_iterations // 2   # the dense branch ran
    assert dense.linear_iterations == scattered.linear_iterations
    np.testing.assert_array_equal(dense.force, scattered.force)


@pytest.mark.parametrize("deferring", [False, True], ids=["every cut settled", "far fields deferred"])
@pytest.mark.parametrize("control", ["load, rotation fixed", "closure"])
def test_a_step_and_the_cut_before_it_share_one_product(comm, control, deferring, monkeypatch):
    """After a cut too large to wait, the next search direction's H d is held between its
    transforms, dᵀHd read off its spectrum; where that step cuts too, H (c − α d) is taken as one
    product and H d's inverse transforms are skipped. With the far fields deferred (DEFER_FROM
    lowered to this grid) a cut is held after only where it could not wait even alone.

    - The solve reaches the active set's state (FORCE_RTOL, as every CG solve here).
    - Fewer inverse transforms than forward ones ran: the joined products were taken (every
      other product runs both).
    - In double precision the solve takes the steps of the CG that never holds (the operator
      made unable to: ``Flexibility.holds`` False), its residuals within 1e-10 at every
      iteration: the two updates of H p differ by the rounding of H (c − α d) against
      − α H d + H c, about 1e-16 of H p a step. A wrong joined update would be repaired only at
      the exact confirmations, after other steps."""
    import roughcontact.normal.constrained_cg as constrained_cg
    from roughcontact.operators.flexibility import Flexibility

    if deferring:
        monkeypatch.setattr(constrained_cg, "DEFER_FROM", 0)
    problem = NormalProblem(rough(64, seed=3), FLAT, comm, operator="fft")
    reference = solve(problem, "ksp", CONTROLS[control])
    convolution = problem.flexibility.convolution
    events = []

    def logged(name, method):
        def call(*args, **kwargs):
            events.append(name)
            return method(*args, **kwargs)
        return call

    monkeypatch.setattr(convolution, "_transform", logged("forward", convolution._transform))
    monkeypatch.setattr(convolution, "backward", logged("inverse", convolution.backward))
    result = solve(problem, "cg", CONTROLS[control])
    assert_same_state(reference, result)
    assert events.count("inverse") < events.count("forward")
    double = CGSettings(precision="double")
    held = solve(problem, "cg", CONTROLS[control], settings=double)
    monkeypatch.setattr(Flexibility, "holds", property(lambda self: False))
    whole = solve(problem, "cg", CONTROLS[control], settings=double)
    problem.destroy()
    assert held.linear_iterations == whole.linear_iterations
    np.testing.assert_allclose(held.residual_history, whole.residual_history, rtol=0, atol=1e-10)


@pytest.mark.parametrize("value", [1, "yes", None])
def test_bad_alternate_return_is_named(value):
    with pytest.raises(InputError, match="alternate_return"):
        CGSettings(alternate_return=value)


@pytest.mark.parametrize("value", [1, "yes", None])
def test_bad_energy_scale_is_named(value):
    with pytest.raises(InputError, match="energy_scale"):
        CGSettings(energy_scale=value)


def test_a_warm_closure_sweep_with_the_energy_scale_is_the_active_sets(comm):
    """Three closures of a sweep, each started from the last one's solution: with the forces
    rescaled to the energy's minimum (the default) and without, the paper's active set's states
    (KSP) to the force tolerance; the rescaling changes the path (the iterations differ)."""
    problem = NormalProblem(rough(64), FLAT, comm, operator="fft")
    closures = (0.04, 0.06, 0.08)
    sweeps = {}
    for scaled in (True, False):
        with make_solver(problem, "cg", settings=CGSettings(energy_scale=scaled)) as solver:
            sweeps[scaled] = [solver.solve_closure(c) for c in closures]
    references = [solve(problem, "ksp", lambda s, c=c: s.solve_closure(c)) for c in closures]
    problem.destroy()
    assert 0.0 < references[0].contact_fraction < references[-1].contact_fraction < 1.0
    for scaled in (True, False):
        for reference, result in zip(references, sweeps[scaled]):
            assert_same_state(reference, result)
    assert [r.linear_iterations for r in sweeps[True]] != [r.linear_iterations for r in sweeps[False]]


def energy(problem, forces, w):
    """Π(p) = ½ pᵀHp − pᵀw over all ranks, H p by the operator's own double-precision product."""
    return float(problem.allsum(0.5 * forces @ problem.displacement(forces) - forces @ w))


@pytest.mark.parametrize("rotation", [(0.0, 0.0), (0.05, -0.02)], ids=["rotation zero", "rotation imposed"])
def test_the_energy_scale_is_the_minimum_of_the_energy_along_the_forces(comm, rotation):
    """Under displacement control the forces are rescaled by s = pᵀw / pᵀHp: Π(s p) is a parabola
    in s, so Π at s is below Π at s (1 ± 1e-3) by ½ (1e-3 s)² pᵀHp, and the rescaled H p is the
    operator's product of the rescaled forces (H is linear; round-off 1e-12 of its largest value),
    the same whether the sums run over every node or over a set of nodes holding the forces.
    At a converged state the scale is 1 to the solve's tolerance: complementarity makes pᵀg = 0,
    so pᵀw = pᵀHp (g = H p − w; 1e-6, the forces' accuracy)."""
    from roughcontact.normal.constrained_cg import _scale_to_energy

    problem = NormalProblem(rough(48), FLAT, comm, operator="fft")
    rigid = np.array([0.08, *rotation])
    w = problem.interpenetration(rigid)
    # forces on the nodes the rigid motion makes interpenetrate, so that pᵀw > 0
    forces = np.random.default_rng(3 + comm.rank).random(problem.gap0.size) * 1e-3 * (w > 0.0)
    displacement = problem.displacement(forces)
    scaled, moved = forces.copy(), displacement.copy()
    s = _scale_to_energy(problem, scaled, moved, w, None)
    curvature = float(problem.allsum(forces @ displacement))
    assert s > 0.0 and s != 1.0
    np.testing.assert_allclose(scaled, s * forces, rtol=1e-15, atol=0)
    np.testing.assert_allclose(moved, problem.displacement(scaled), rtol=0,
                               atol=1e-12 * float(problem.allmax(np.abs(moved).max())))
    # the CG's calls name the free set's nodes (a superset of the forces' own): the same s and forces
    on_set, on_set_displacement = forces.copy(), displacement.copy()
    nodes = np.flatnonzero((forces > 0.0) | (np.arange(forces.size) % 3 == 0))
    assert _scale_to_energy(problem, on_set, on_set_displacement, w, nodes) == pytest.approx(s, rel=1e-12)
    np.testing.assert_allclose(on_set, scaled, rtol=1e-12, atol=0)
    np.testing.assert_allclose(on_set_displacement, moved, rtol=1e-12, atol=0)
    lowest = energy(problem, scaled, w)
    for factor in (1 - 1e-3, 1 + 1e-3):
        assert energy(problem, factor * scaled, w) - lowest == pytest.approx(0.5 * (1e-3 * s) ** 2 * curvature,
                                                                             rel=1e-3)
    with make_solver(problem, "cg") as solver:
        solver.solve_closure(0.08, rotation=rotation, gather=False)
        solved = solver.forces.copy()             # the state's forces, this rank's nodes
    converged = _scale_to_energy(problem, solved, problem.displacement(solved), w, None)
    problem.destroy()
    assert abs(converged - 1.0) <= 1e-6


def test_hertz_on_the_fft_path_beyond_dense_grids(comm):
    """Hertz at a/s = 16, 32, 64 (a 211² grid: 15 GiB as a dense matrix): RMS errors of the
    load and contact radius over four approaches (a single approach's error oscillates as the
    contact edge crosses grid nodes) within 1 %, 0.5 %, 0.25 % of the closed form, each
    smaller than the last (the punch grid's error is O(s)). Measured: see the assertion text.
    """
    radius, spacing = 1.0, 1.0
    errors = []
    for a_over_s, bound in ((16, 1e-2), (32, 5e-3), (64, 2.5e-3)):
        n = int(3.3 * a_over_s) | 1
        topo = Topography(sphere_heights(n, spacing, radius), spacing)
        problem = NormalProblem(topo, FLAT, comm, operator="fft")
        load_errors, radius_errors = [], []
        with make_solver(problem, "cg") as solver:
            for factor in (0.85, 0.9, 0.95, 1.0):
                delta = (factor * a_over_s * spacing) ** 2 / radius
                res = solver.solve_closure(delta)
                load_errors.append(res.load / hertz.load(delta, radius, FLAT.contact_modulus) - 1.0)
                radius_errors.append(np.sqrt(res.contact_area / np.pi) / hertz.contact_radius(delta, radius) - 1.0)
        problem.destroy()
        rms = (float(np.sqrt(np.mean(np.square(load_errors)))), float(np.sqrt(np.mean(np.square(radius_errors)))))
        assert max(rms) < bound, f"a/s = {a_over_s}: RMS load, radius errors {rms}"
        errors.append(rms)
    assert errors[0][0] > errors[1][0] > errors[2][0], errors
    assert errors[0][1] > errors[1][1] > errors[2][1], errors


def test_flat_punch_stiffness_on_a_fine_grid(comm):
    """A flat punch of 121 spacings diameter: P/δ = 2 a E* within 0.1 % (measured 0.05 %)."""
    n, spacing = 125, 1.0
    footprint = disc((n, n), spacing, 121 * spacing)
    topo = Topography(np.zeros((n, n)), spacing, footprint)
    problem = NormalProblem(topo, FLAT, comm, operator="fft")
    res = solve(problem, "cg", lambda s: s.solve_closure(1e-3))
    problem.destroy()
    a = np.sqrt(footprint.sum() / np.pi) * spacing          # radius of the footprint's area
    assert res.full_contact
    assert res.load / 1e-3 == pytest.approx(2 * a * FLAT.contact_modulus, rel=1e-3)


def test_periodic_wavy_surface_follows_westergaard(comm):
    """A sinusoidal surface h = g cos(2πx/λ) on a periodic cell (one wavelength): Westergaard's
    solution gives contact over a half-width a with p̄ = p* sin²(πa/λ), p* = π E* g/λ, and full
    contact with p(x) = p̄ + p* cos(2πx/λ) above p*. At 128 nodes per wavelength the contact
    fraction is within two nodes (1.6 %) and the full-contact pressure within 0.5 % of p*."""
    n, wavelength, amplitude = 128, 1.0, 1e-3
    spacing = wavelength / n
    x = np.arange(n) * spacing
    heights = np.repeat((amplitude * np.cos(2 * np.pi * x / wavelength))[:, None], 8, axis=1)
    topo = Topography(heights, spacing)
    problem = NormalProblem(topo, FLAT, comm, operator="fft-periodic")
    p_star = np.pi * FLAT.contact_modulus * amplitude / wavelength
    area = n * 8 * spacing**2
    half = solve(problem, "cg", lambda s: s.solve_load(0.5 * p_star * area, rotation=(0.0, 0.0)))
    assert half.contact_fraction == pytest.approx(0.5, abs=2.0 / n)
    full = solve(problem, "cg", lambda s: s.solve_load(1.5 * p_star * area, rotation=(0.0, 0.0)))
    assert full.full_contact
    expected = 1.5 * p_star + p_star * np.cos(2 * np.pi * x / wavelength)
    np.testing.assert_allclose(full.pressure[:, 3], expected, rtol=0, atol=5e-3 * p_star)
    with pytest.raises(InputError, match="periodic"):
        solve(problem, "cg", lambda s: s.solve_closure(1e-4))
    with pytest.raises(InputError, match="periodic"):
        solve(problem, "cg", lambda s: s.solve_load(0.1))
    with pytest.raises(InputError, match="periodic"):
        make_solver(problem, "ksp")
    problem.destroy()


def test_near_full_contact_is_solved_or_named(comm):
    """A load that closes all but a few nodes: the state satisfies the contact conditions,
    checked independently of the solver (p ≥ 0, gap ≥ 0 off S, gap 0 on S, equilibrium)."""
    topo = rough(32, seed=5)
    problem = NormalProblem(topo, FLAT, comm, operator="fft")
    for method in ("cg", "ksp"):
        res = solve(problem, method, lambda s: s.solve_load(2.0, rotation=(0.0, 0.0)))
        assert res.contact_fraction > 0.95
        footprint = topo.footprint
        forces = res.force[footprint]
        local = forces[problem.start:problem.stop]
        gap = problem.displacement(local) - problem.interpenetration(np.array([res.closure, 0.0, 0.0]))
        scale = np.ptp(topo.heights)
        contact = res.contact[footprint][problem.start:problem.stop]
        assert np.all(forces >= 0.0) and forces.sum() == pytest.approx(2.0, rel=1e-12)
        assert np.all(gap[~contact] >= -1e-8 * scale) and np.all(np.abs(gap[contact]) <= 1e-8 * scale)
    problem.destroy()


@pytest.mark.parametrize("rotation_from", [1, None], ids=["rotation with the forces", "Newton on the rotation"])
def test_failures_raise_named_errors(comm, rotation_from):
    """Too few iterations raise CG_MAX_ITERATIONS, the primal–dual steps' products counted as the
    constrained CG's iterations are; a bad setting or a use after destroy is named."""
    problem = NormalProblem(rough(48), FLAT, comm, operator="fft")
    with pytest.raises(ConvergenceError) as info:
        solve(problem, "cg", CONTROLS["load, rotation free"],
              settings=CGSettings(max_iterations=3, rotation_from=rotation_from), nested=False)
    assert info.value.reason == "CG_MAX_ITERATIONS"
    assert ("primal-dual" if rotation_from else "bound-constrained") in str(info.value)
    with pytest.raises(InputError, match="preconditioner"):
        CGSettings(preconditioner="multigrid")
    with pytest.raises(InputError, match="method"):
        make_solver(problem, "newton")
    solver = make_solver(problem, "cg")
    solver.destroy()
    with pytest.raises(DestroyedError, match="destroyed"):
        solver.solve_load(0.01)
    problem.destroy()
    with pytest.raises(DestroyedError):
        make_solver(problem, "cg")


def test_unpreconditioned_cg_reaches_the_same_state(comm):
    """Polonsky & Keer's original iteration (no preconditioner) is the same solver, slower."""
    problem = NormalProblem(rough(64, seed=3), FLAT, comm, operator="fft")
    plain = solve(problem, "cg", CONTROLS["load, rotation fixed"], settings=CGSettings(preconditioner="none"))
    fourier = solve(problem, "cg", CONTROLS["load, rotation fixed"])
    assert_same_state(plain, fourier)
    assert fourier.linear_iterations < plain.linear_iterations
    problem.destroy()


@pytest.mark.parametrize("rotation_from", [1, None], ids=["with the forces", "Newton"])
@pytest.mark.parametrize("levels, dimension, seed", [(4, 2.3, 1), (4, 2.5, 2), (5, 2.1, 3), (5, 2.5, 3)])
def test_free_rotation_at_a_few_contact_nodes(comm, levels, dimension, seed, rotation_from, settle_calls):
    """Loads so small that 3–6 nodes must surround the load point, rotations free: the CG reaches
    the active set's state, with the rotation found with the forces (the default; where a held
    set cannot carry the moments the steps give up and the Newton goes on: here on the second
    surface, the steps holding on the other three: read where the steps return) and by the Newton
    on θ alone (these cases made CG iterations with the moments as linear constraints of every
    step lose their support)."""
    from roughcontact.surfaces import midpoint_surface

    rock = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
    topo = midpoint_surface(levels, dimension, spacing=1e-4, rms_height=1e-5, seed=seed)
    problem = NormalProblem(topo, rock, comm, operator="fft")
    load = 5e-5 * rock.contact_modulus * topo.nominal_area
    reference = solve(problem, "ksp", lambda s: s.solve_load(load))
    result = solve(problem, "cg", lambda s: s.solve_load(load), settings=CGSettings(rotation_from=rotation_from))
    settled = [settled.converged for _, settled in settle_calls]
    if rotation_from is None:
        assert settled == []
    else:
        assert settled == [(levels, dimension, seed) != (4, 2.5, 2)]      # one level, the steps' one call
    assert 3 <= reference.contact.sum() <= 12
    assert_same_state(reference, result)
    np.testing.assert_allclose(result.rotation, reference.rotation, rtol=1e-6)
    problem.destroy()


@pytest.mark.parametrize("rotation_from", [1, None], ids=["with the forces", "Newton"])
def test_a_contact_on_a_line_through_the_load_point(comm, rotation_from):
    """The one failure of the few-node map (benchmarks/bench_rotation.py --parts few, 1 of 270
    cells): 17², Δ = 2.1, seed 4, 1e-5 E* A0, where the active set's contact is two corner nodes
    on the grid's diagonal through the centroid, each carrying P/2. Two nodes on a line through
    the load point hold the moments but not the rotation about that line: the state's forces are
    unique, its rotation is not (any about the diagonal that brings no third node into contact).
    The steps refuse the set (its nodes on one line), and the Newton's trust region took a step of
    its whole radius along the rotation the set does not stiffen, from a load residual that is
    round-off along it, at every try: the line search failed at 2.05e-8 against load_tol 1e-8 on
    one rank. Now the forces are the active set's, the moments within load_tol, and the rigid
    motion the same at the two supports (Eq. 7: δz − θx y − θy x at (x, y) = ±(−8s, 8s), so δz
    the same and Δθx = Δθy)."""
    from roughcontact.surfaces import midpoint_surface

    rock = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
    topo = midpoint_surface(4, 2.1, spacing=1e-4, rms_height=1e-5, seed=4)
    problem = NormalProblem(topo, rock, comm, operator="fft")
    load = 1e-5 * rock.contact_modulus * topo.nominal_area
    reference = solve(problem, "ksp", lambda s: s.solve_load(load))
    result = solve(problem, "cg", lambda s: s.solve_load(load), settings=CGSettings(rotation_from=rotation_from))
    carrying = np.flatnonzero(reference.force > FORCE_RTOL * reference.force.max())
    assert carrying.tolist() == [16, 16 * 17]                     # the corners (0, 16) and (16, 0)
    np.testing.assert_allclose(reference.force.ravel()[carrying], load / 2, rtol=1e-12)
    assert_same_state(reference, result)
    assert np.abs(result.moments).max() <= CGSettings().load_tol * load * problem.extent
    assert result.closure == pytest.approx(reference.closure, rel=1e-6)
    change = np.subtract(result.rotation, reference.rotation)
    assert abs(change[0] - change[1]) <= 1e-6 * np.abs(reference.rotation).max()
    problem.destroy()


@pytest.mark.parametrize("rotation_from", [1, None], ids=["with the forces", "Newton"])
@pytest.mark.parametrize("levels, factor, load", [(8, 4, 30.0), (9, 8, 60.0), (11, 32, 100.0)])
def test_free_rotation_does_not_cycle_on_decimated_fractal_surfaces(comm, levels, factor, load, rotation_from):
    """65² grids decimated from finer midpoint surfaces (what the coarsest level of a nested start
    solves), 7–13 nodes in contact, rotation free. The Newton on θ alternated between a step accepted
    by Armijo on Φ (the load residual rising) and one accepted because the load residual halved (Φ
    rising) for all its 50 steps — relative load residual 0.73 on the third case, the coarsest level
    of a 2049² farm task, whose every finer level then started from independent punches (2 of 150
    such cases failed: 2 dimensions × 15 seeds × 5 loads). Now the state is the equilibrium (Σ p = P
    and zero moments about the centroid within load_tol) and the active set's, with the rotation
    found with the forces (the default) and by the Newton alone."""
    from roughcontact.surfaces import coarsen, midpoint_surface

    rock = Interface(Material(20e9, 0.0), Material(20e9, 0.0))
    topo = coarsen(midpoint_surface(levels, 2.2, spacing=1e-4, rms_height=1e-5, seed=1), factor, "decimate")
    problem = NormalProblem(topo, rock, comm, operator="dense")
    result = solve(problem, "cg", lambda s: s.solve_load(load), settings=CGSettings(rotation_from=rotation_from))
    reference = solve(problem, "ksp", lambda s: s.solve_load(load))
    assert 4 <= result.contact.sum() <= 16
    assert result.load == pytest.approx(load, rel=1e-8)
    assert np.abs(result.moments).max() <= 1e-8 * load * problem.extent
    assert_same_state(reference, result)
    problem.destroy()


@pytest.mark.parametrize("control", ["load, rotation free", "load and moments"])
def test_free_rotation_resolves_loosely_first_and_returns_a_state_resolved_for_load_tol(comm, control):
    """The inexact Newton on θ (``rotation_from=None``: by default the rotation is found with the
    forces): the first evaluation is resolved to FIRST_TOL (1e-5, looser than
    the solver's tol), later ones to 1e-3 of the square of the load residual they step from, and
    the state returned to CONFIRM_SHARE (0.1) of load_tol, the floor no state here needed
    lowered. Its rotation is the active set's to 1e-6 (the bound of the few-node cases above)."""
    from roughcontact.normal.constrained_cg import FIRST_TOL
    from roughcontact.normal.rigid_motion import CONFIRM_SHARE

    problem = NormalProblem(rough(64, seed=6), FLAT, comm, operator="fft")
    reference = solve(problem, "ksp", CONTROLS[control])
    settings, tolerances = CGSettings(rotation_from=None), []       # the Newton, not the steps
    with make_solver(problem, "cg", settings=settings) as solver:
        inner = solver._constrained_cg

        def recording(rigid, free, loads, forces, tol=None, **options):
            tolerances.append(tol)
            return inner(rigid, free, loads, forces, tol=tol, **options)

        solver._constrained_cg = recording
        result = CONTROLS[control](solver)
    assert tolerances[0] == FIRST_TOL > settings.tol
    assert tolerances[-1] == pytest.approx(CONFIRM_SHARE * settings.load_tol, rel=1e-12)
    assert tolerances[-1] < tolerances[0]
    np.testing.assert_allclose(result.rotation, reference.rotation, rtol=1e-6)
    problem.destroy()


def test_a_trial_starts_from_the_forces_the_hessian_predicts(comm):
    """On a fixed contact set the forces are linear in the rotation at a constant load, with
    derivative X = H_SS⁻¹ (C_θ − 1 μᵀ), Σ X = 0 (the Hessian's Krylov solutions): the start a
    Newton trial gets at θ + Δθ is the solved state there, where the last evaluation's forces
    are off by the whole change. To the Krylov solves' rtol: their residual at 1e-3 of the
    right-hand side's bounds the solutions' error by κ rtol, κ = 12 for this set's block (an
    explicit one, unpreconditioned; 10 on Σ = 0): bound 1.2e-2 of the change, 2.8e-3 measured.
    X itself is checked to 1e-8 against LAPACK below."""
    from roughcontact.normal.constrained_cg import ConstrainedCGSolver

    problem = NormalProblem(rough(64, seed=7), FLAT, comm, operator="fft")
    load = 0.01 * problem.topography.nominal_area
    loads = np.array([load, 0.0, 0.0])
    with ConstrainedCGSolver(problem, CGSettings(tol=1e-12), nested=False) as solver:
        r0 = np.array([0.0, 1e-3, -5e-4])
        p, _ = solver._start(r0.copy(), [0], loads)
        s0, r0 = solver._constrained_cg(r0, [0], loads, p)
        solver._stiffness(s0.active)
        r1 = r0 + np.array([0.0, 2e-7, 1e-7])
        s1, r1 = solver._constrained_cg(r1, [0], loads, s0.pressure)
        predicted = solver._predicted(r0, s0.pressure, r1)
    assert np.array_equal(s0.active, s1.active)                     # the set held: linear there
    change = np.sqrt(problem.allsum(np.sum((s1.pressure - s0.pressure) ** 2)))
    error = np.sqrt(problem.allsum(np.sum((predicted - s1.pressure) ** 2)))
    assert change > 0.0 and error <= 1.2e-2 * change
    problem.destroy()


@pytest.mark.parametrize("explicit", [True, False], ids=["explicit block", "matrix-free block"])
def test_the_rotations_hessian_is_the_schur_complement_over_the_approach(comm, explicit):
    """The CG's Hessian over (θx, θy), two Krylov solves at a constant load, is the Schur
    complement over δz of K = C_Sᵀ H_SS⁻¹ C_S (Eq. 8), and its solutions are the forces'
    response X = H_SS⁻¹ (C_θ − 1 μᵀ) with Σ X = 0: both against H_SS assembled from the Eq. 10
    table and solved by LAPACK, to 1e-8 (the Krylov solves at rtol 1e-12 in double precision,
    the block's condition number about 10), on any number of ranks; Σ X vanishes to round-off
    (1e-12 of Σ|X|)."""
    from roughcontact.normal.constrained_cg import ConstrainedCGSolver
    from roughcontact.operators.kernel import punch_kernel
    from roughcontact.petsc import OptionsScope

    problem = NormalProblem(rough(48, seed=3), FLAT, comm, operator="fft")
    flexibility = problem.flexibility
    flexibility.explicit_fits = lambda count, largest: explicit
    scope = OptionsScope("normal_rotation_", {"ksp_rtol": 1e-12})
    try:
        with ConstrainedCGSolver(problem, CGSettings(precision="double"), nested=False) as solver:
            solver.solve_load(0.01 * problem.topography.nominal_area, rotation=(0.0, 0.0))
            hessian, _ = solver._stiffness(solver.active)
            nodes, basis = solver._basis
            free_block = solver._krylov.sub.getType() == PETSc.Mat.Type.PYTHON
    finally:
        scope.close()
    assert free_block != explicit
    grid = np.concatenate(comm.allgather(problem.nodes[nodes]))
    columns = np.concatenate(comm.allgather(problem.columns_at(nodes)))
    response = np.concatenate(comm.allgather(basis))
    table = punch_kernel(flexibility.shape, flexibility.spacing, flexibility.compliance)
    solved = np.linalg.solve(table_block(table, grid, grid), columns)
    stiffness = columns.T @ solved
    schur = stiffness[1:, 1:] - np.outer(stiffness[1:, 0], stiffness[0, 1:]) / stiffness[0, 0]
    exact = solved[:, 1:] - np.outer(solved[:, 0], stiffness[0, 1:]) / stiffness[0, 0]
    assert grid.shape[0] > 20
    # the load's coupling matters here: K's own block over the rotations is not the answer
    assert np.abs(stiffness[1:, 1:] - schur).max() > 1e-3 * np.abs(schur).max()
    np.testing.assert_allclose(hessian, schur, rtol=0, atol=1e-8 * np.abs(schur).max())
    np.testing.assert_allclose(response, exact, rtol=0, atol=1e-8 * np.abs(exact).max())
    assert np.all(np.abs(response.sum(axis=0)) <= 1e-12 * np.abs(response).sum(axis=0))
    problem.destroy()


@pytest.mark.parametrize("pc_type", [None, "jacobi"], ids=["default pc", "jacobi"])
@pytest.mark.parametrize("explicit", [True, False], ids=["explicit block", "matrix-free block"])
def test_solves_at_a_constant_load_on_any_set(comm, explicit, pc_type):
    """KSPSubsolver(keep_load=True) solves H_SS x + μ 1 = b, Σ x = 0 (the saddle point of the
    rotation's Hessian) on a set, on a different set after it (the block rebuilt), on a set in
    the first rows only (a rank of two without nodes of it) and on one node (x = 0): against
    LAPACK on the bordered matrix made from the Eq. 10 table, to 1e-8 (rtol 1e-12 in double
    precision, the blocks' condition numbers about 10), with a pc_type of the options database
    too (it preconditions the block; the KSP keeps the iterates on Σ = 0)."""
    from roughcontact.normal.petsc import KSPSubsolver
    from roughcontact.operators.kernel import punch_kernel

    problem = NormalProblem(rough(32, seed=2), FLAT, comm, operator="fft")
    flexibility = problem.flexibility
    flexibility.explicit_fits = lambda count, largest: explicit
    nodes = problem.nodes
    rng = np.random.default_rng(11)
    chosen = rng.random((2, 32, 32)) < 0.1                        # the same sets on any rank count
    rhs_field = rng.standard_normal((32, 32))
    table = punch_kernel(flexibility.shape, flexibility.spacing, flexibility.compliance)
    sets = [chosen[0][nodes[:, 0], nodes[:, 1]], chosen[1][nodes[:, 0], nodes[:, 1]],
            chosen[0][nodes[:, 0], nodes[:, 1]] & (nodes[:, 0] < 4),
            (nodes[:, 0] == 7) & (nodes[:, 1] == 9)]
    options = {"ksp_rtol": 1e-12} | ({} if pc_type is None else {"pc_type": pc_type})
    solver = KSPSubsolver(flexibility, prefix="test_kept_", options=options, keep_load=True)
    try:
        for active in sets:
            solver.set_active(active)
            if not explicit and pc_type is None:
                assert solver.sub.getType() == PETSc.Mat.Type.PYTHON
            rhs = rhs_field[nodes[active, 0], nodes[active, 1]]
            x, _ = solver.solve(rhs, np.zeros(rhs.size))
            grid = np.concatenate(comm.allgather(nodes[active]))
            whole_rhs = np.concatenate(comm.allgather(rhs))
            whole_x = np.concatenate(comm.allgather(x))
            k = grid.shape[0]
            bordered = np.ones((k + 1, k + 1))
            bordered[k, k] = 0.0
            bordered[:k, :k] = table_block(table, grid, grid)
            exact = np.linalg.solve(bordered, np.append(whole_rhs, 0.0))[:k]
            if k == 1:
                assert np.all(whole_x == 0.0)
                continue
            np.testing.assert_allclose(whole_x, exact, rtol=0, atol=1e-8 * np.abs(exact).max())
            assert abs(whole_x.sum()) <= 1e-12 * np.abs(whole_x).sum()
    finally:
        solver.destroy()
    problem.destroy()


@pytest.mark.parametrize("tol", [1e-3, 1e-6, 1e-11])
def test_complementary_energy_of_an_inexact_state_is_the_inner_value(comm, tol):
    """Φ of a state the CG resolved only to ``tol`` (load control at an imposed rotation, what the
    Newton on θ evaluates) is the inner problem's value at its forces, pᵀw − ½ pᵀHp − δz P with
    Hp an independent product, to round-off (1e-12 of the terms); ½ pᵀw − δz P alone, the
    value at the exact solution, is off by ½ pᵀg, which the loose solves make larger than that.
    This is what lets the Newton's line search compare states resolved to different tolerances."""
    from roughcontact.normal.constrained_cg import ConstrainedCGSolver
    from roughcontact.normal.rigid_motion import _evaluate

    problem = NormalProblem(rough(64, seed=5), FLAT, comm, operator="fft")
    load = 0.01 * problem.topography.nominal_area
    loads = np.array([load, 0.0, 0.0])
    with ConstrainedCGSolver(problem, CGSettings(tol=tol), nested=False) as solver:
        motion = np.array([0.0, 2e-3, -1e-3])                       # δz found, rotation imposed
        start, _ = solver._start(motion.copy(), [0], loads)
        evaluate = lambda r, needed: solver._constrained_cg(r, [0], loads, start, tol=tol)  # noqa: E731
        state, rigid, phi, _ = _evaluate(problem, motion, [0], [0], loads, evaluate, np.inf)
    p = state.pressure
    w = problem.interpenetration(rigid)
    terms = problem.allsum(np.array([p @ w, p @ problem.displacement(p)]))
    inner = terms[0] - 0.5 * terms[1] - rigid[0] * load
    assert state.residual <= tol
    assert phi == pytest.approx(inner, rel=0, abs=1e-12 * abs(terms).max())
    exact_form = 0.5 * terms[0] - rigid[0] * load
    if tol >= 1e-6:
        assert abs(exact_form - inner) > 1e-9 * abs(terms).max()
    problem.destroy()


@pytest.mark.slow
@pytest.mark.parametrize("rotation_from", [1, None], ids=["with the forces", "Newton"])
def test_free_rotation_converges_on_every_coarse_level_like_surface(comm, rotation_from):
    """The map behind the previous test: 65² grids decimated by 4 from 257² and by 8 from 513²
    midpoint surfaces (Δ = 2.2, seeds 1–15), five loads from 30 to 200 N (1 to 115 nodes), rotation
    free, each from a cold start: every one converges to zero moments (2 of the 150 cycled before
    Φ was kept from rising), with the rotation found with the forces (9 of the 150 gave up for the
    Newton) and by the Newton alone; about 10 s each."""
    from roughcontact.surfaces import coarsen, midpoint_surface

    rock = Interface(Material(20e9, 0.0), Material(20e9, 0.0))
    for levels, factor in ((8, 4), (9, 8)):
        for seed in range(1, 16):
            topo = coarsen(midpoint_surface(levels, 2.2, spacing=1e-4, rms_height=1e-5, seed=seed), factor,
                           "decimate")
            with NormalProblem(topo, rock, comm, operator="dense") as problem:
                for load in (30.0, 60.0, 100.0, 150.0, 200.0):
                    result = solve(problem, "cg", lambda s: s.solve_load(load),
                                   settings=CGSettings(rotation_from=rotation_from))
                    assert np.abs(result.moments).max() <= 1e-8 * load * problem.extent, (levels, seed, load)


@pytest.mark.parametrize("control", sorted(CONTROLS))
def test_mixed_precision_reaches_the_double_state(comm, control):
    """Single-precision direction products and preconditioner (the default) reach the state of
    all-double CG to the force tolerance, with the reported residual below tol: the residual
    is confirmed on a double-precision H p, so the precision cannot loosen it."""
    problem = NormalProblem(rough(64, seed=4), FLAT, comm, operator="fft")
    double = solve(problem, "cg", CONTROLS[control], settings=CGSettings(precision="double"))
    mixed = solve(problem, "cg", CONTROLS[control])
    assert_same_state(double, mixed)
    assert mixed.residual <= CGSettings().tol
    problem.destroy()


def test_mixed_precision_keeps_the_iteration_count_at_tight_tolerance(comm):
    """Free rotation at 65² (the coarse level of a 513² start), whose last inner solves run to
    1e-11: the exact H p that confirms convergence differs from the updated one by the single
    products' round-off (~1e-10 here), and the conjugate directions restart there. Without
    the restart the mixed CG took 1084 iterations against 310 in double (at 129² it hit
    the iteration limit); with it 334. Allowed: 1.25 times the double count."""
    from roughcontact.surfaces import coarsen, midpoint_surface

    rock = Interface(Material(20e9, 0.0), Material(20e9, 0.0))
    fine = midpoint_surface(9, 2.3, spacing=1e-4, rms_height=1e-5, seed=7)
    topo = coarsen(fine, 8, "decimate")
    problem = NormalProblem(topo, rock, comm, operator="fft")
    h = fine.heights
    load = solve(problem, "ksp", lambda s: s.solve_closure(float(h.max() - np.quantile(h, 0.85)))).load
    double = solve(problem, "cg", lambda s: s.solve_load(load), settings=CGSettings(precision="double"))
    mixed = solve(problem, "cg", lambda s: s.solve_load(load))
    assert_same_state(double, mixed)
    assert mixed.linear_iterations <= 1.25 * double.linear_iterations
    problem.destroy()


@pytest.mark.parametrize("control", sorted(CONTROLS))
def test_edge_correction_reaches_the_plain_preconditioners_state(comm, control):
    """The preconditioner's edge correction (the default) changes the path, not the state: the
    same forces to the force tolerance as the plain R_S C⁻¹ R_Sᵀ (edge_share 0)."""
    problem = NormalProblem(rough(64, seed=6), FLAT, comm, operator="fft")
    plain = solve(problem, "cg", CONTROLS[control], settings=CGSettings(edge_share=0.0))
    corrected = solve(problem, "cg", CONTROLS[control])
    assert_same_state(plain, corrected)
    assert corrected.residual <= CGSettings().tol
    problem.destroy()


def test_a_correction_that_loses_positivity_falls_back_to_the_plain_preconditioner(comm, monkeypatch):
    """Edge weights of twice C⁻¹'s diagonal make the corrected preconditioner indefinite, so gᵀz
    goes negative; the CG then takes the plain preconditioner's direction (and restarts), and
    reaches the plain state in about the plain count (13 against 11). Without that fallback the
    same solve took 166 iterations (and, run with two FFT threads, more than 2000)."""
    from roughcontact.operators.preconditioner import FourierPreconditioner

    problem = NormalProblem(rough(64, seed=6), FLAT, comm, operator="fft")
    control = CONTROLS["load, rotation fixed"]
    plain = solve(problem, "cg", control, settings=CGSettings(edge_share=0.0))
    monkeypatch.setattr(FourierPreconditioner, "weights_from_sums",
                        lambda self, sums, share: np.full(sums.size, 2 * self.inverse_diagonal))
    rescued = solve(problem, "cg", control, settings=CGSettings(max_iterations=500))
    assert_same_state(plain, rescued)
    assert rescued.linear_iterations <= 2 * plain.linear_iterations
    problem.destroy()


def test_the_edge_correction_is_dropped_where_the_set_cycles(comm, monkeypatch):
    """Above the single precision's floor, no new lowest residual for 2 × renew iterations drops the
    correction for the rest of the solve (near full contact at 1024², Δ = 2.8, the corrected
    CG cycled for 232 iterations against 84 plain; with the rule 105). No small grid cycles
    long enough, so the floor is taken away (every residual counts as above it) and renew = 1:
    the rule fires on a near-full 64² contact, the solve goes on with the plain preconditioner
    and reaches the plain state."""
    import roughcontact.normal.constrained_cg as constrained_cg
    from roughcontact.normal.constrained_cg import ConstrainedCGSolver

    n = 64
    topo = fourier_surface(n, 1.0 / n, fractal_dimension=2.5, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8.0 / n, periodic=False, seed=1)
    problem = NormalProblem(topo, FLAT, comm, operator="fft")
    control = lambda s: s.solve_load(1.0 * topo.nominal_area, rotation=(0.0, 0.0))    # noqa: E731
    plain = solve(problem, "cg", control, settings=CGSettings(edge_share=0.0))
    asked = []
    weights = ConstrainedCGSolver._edge_weights

    def recorded(*args):
        asked.append(args[5])                          # correcting (after self, edges, nodes, members, single)
        return weights(*args)

    monkeypatch.setattr(ConstrainedCGSolver, "_edge_weights", recorded)
    monkeypatch.setattr(constrained_cg, "SINGLE_FLOOR", -1.0)
    dropped = solve(problem, "cg", control, settings=CGSettings(renew=1))
    assert asked[0] and not asked[-1]                  # corrected first, plain after the rule fired
    assert_same_state(plain, dropped)
    problem.destroy()


def test_bad_precision_is_named():
    with pytest.raises(InputError, match="precision"):
        CGSettings(precision="half")


def double_and_mixed_near_full_contact(n: int, comm):
    """Load-controlled CG solves, all-double and mixed precision, of an n² Fourier surface of
    fractal dimension 2.5 at 1 E* (near full contact: over 80 % of the nodes in contact, checked),
    the two states checked equal; (double, mixed)."""
    topo = fourier_surface(n, 1.0 / n, fractal_dimension=2.5, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8.0 / n, periodic=False, seed=1)
    problem = NormalProblem(topo, FLAT, comm, operator="fft")
    control = lambda s: s.solve_load(1.0 * topo.nominal_area, rotation=(0.0, 0.0))    # noqa: E731
    try:
        double = solve(problem, "cg", control, settings=CGSettings(precision="double"))
        mixed = solve(problem, "cg", control)
    finally:
        problem.destroy()
    assert double.contact_fraction > 0.8
    assert_same_state(double, mixed)
    return double, mixed


def test_mixed_precision_falls_back_to_double_where_it_stalls(comm):
    """Near full contact (Δ = 2.5 at 1 E*, 87 % of 512² in contact) single-precision products
    stop the residual falling at ~1e-7 (it rose to 8e-7: 949 iterations against 54 in double);
    the CG takes every product in double once the residual has not reached a new lowest value
    for `renew` iterations. Allowed: 1.5 times the double count (measured 71 against 54 before
    H p was taken exactly where the residual first reaches SINGLE_FLOOR, which now removes most
    of the stall: the test below)."""
    double, mixed = double_and_mixed_near_full_contact(512, comm)
    assert mixed.linear_iterations <= 1.5 * double.linear_iterations


@pytest.mark.parametrize("load", [3.0, 10.0])
def test_powells_test_restarts_where_the_set_changes_the_gap(comm, load):
    """Pressed into full contact (64² at 3 and 10 E* × area) the free set grows from the Winkler
    start's: the conjugate directions made on the earlier sets are far from conjugate on the
    later ones. Powell's test (restart 0.2) restarts them there and keeps them elsewhere, and
    takes fewer iterations than never restarting (14 / 15 against 18 / 20) or restarting at
    every step (17 / 18; preconditioned steepest descent), the same on 1 and 2 ranks (26 / 29,
    34 / 58 and 77 / 75 while C's period was the grid's own, blind to the grid's edges). All
    three reach the same state: the restarts change the path only. The restarts are compared
    without returning nodes held back (``alternate_return``): with them, restarting at every
    step ties with Powell's test at 3 E* (16 / 15, 36 / 20 and 16 / 18)."""
    topo = rough(64)
    problem = NormalProblem(topo, FLAT, comm, operator="fft")
    control = lambda s: s.solve_load(load * topo.nominal_area, rotation=(0.0, 0.0))    # noqa: E731
    runs = {restart: solve(problem, "cg", control, settings=CGSettings(restart=restart, alternate_return=False))
            for restart in (0.2, np.inf, 0.0)}
    assert runs[0.2].full_contact
    for other in (np.inf, 0.0):
        assert_same_state(runs[0.2], runs[other])
        assert runs[0.2].linear_iterations < runs[other].linear_iterations, \
            {r: run.linear_iterations for r, run in runs.items()}
    problem.destroy()


@pytest.mark.parametrize("restart", [-0.1, float("nan")])
def test_bad_restart_is_named(restart):
    with pytest.raises(InputError, match="restart"):
        CGSettings(restart=restart)


def test_mixed_precision_takes_the_double_path_near_full_contact(comm):
    """The single products' errors pile up in the updated H p with the size of the steps since
    the last exact one, the first steps being of the size of the starting gap: near full contact
    (Δ = 2.5 at 1 E*, 128², 87 % in contact) they stalled the residual at ~1e-7, 47 iterations
    against 38 in double. One exact H p where the residual first reaches SINGLE_FLOOR leaves the
    errors of the later steps, 1e-5 of the first ones' size, far below tol: the mixed solve then
    took the double one's iterations (38 both). Since C's period is longer than the grid (the
    preconditioner sees the grid's edges) the solve is a cold one of 17 iterations in double, the
    residual reaches SINGLE_FLOOR at iteration 12 of 16, and the mixed one takes 20 (22 without
    the exact product at the floor; the same on 1 and 2 ranks). Allowed: 3 more."""
    double, mixed = double_and_mixed_near_full_contact(128, comm)
    assert mixed.linear_iterations <= double.linear_iterations + 3, (mixed.linear_iterations,
                                                                      double.linear_iterations)


@pytest.mark.parametrize("control", sorted(CONTROLS))
def test_deferred_far_fields_reach_the_same_state(comm, control, monkeypatch):
    """Cut forces whose far field waits (``defer``, the default) change the path, not the state:
    the same forces to the force tolerance as settling every cut at once (defer 0). A 64² grid
    defers nothing (below DEFER_FROM); here any grid and any number of nodes may (DEFER_FROM 1,
    DEFER_NODES 1), so that every control takes the deferring branches, and the test checks that
    some far field did wait."""
    import roughcontact.normal.constrained_cg as constrained_cg
    from roughcontact.operators.near_field import PendingFarField

    problem = NormalProblem(rough(64, seed=6), FLAT, comm, operator="fft")
    # the far fields wait in the constrained CG's steps: with the rotation free, the Newton's
    at_once = solve(problem, "cg", CONTROLS[control], settings=CGSettings(defer=0.0, rotation_from=None))
    deferred = []
    defer = PendingFarField.defer

    def recorded(self, displacement, nodes, forces, mass, count):
        deferred.append(count)
        return defer(self, displacement, nodes, forces, mass, count)

    monkeypatch.setattr(PendingFarField, "defer", recorded)
    monkeypatch.setattr(constrained_cg, "DEFER_NODES", 1)
    monkeypatch.setattr(constrained_cg, "DEFER_FROM", 1)
    waited = solve(problem, "cg", CONTROLS[control], settings=CGSettings(rotation_from=None))
    assert deferred
    assert_same_state(at_once, waited)
    assert waited.residual <= CGSettings().tol
    problem.destroy()


def test_deferred_far_fields_save_products(comm, monkeypatch):
    """On the large-grid scene at 512² (1.9 % contact) the default defer starts fewer padded
    products than settling every cut at once (forward transforms, measured 20 against 22 on one
    rank), and reaches the same state. In all it took as many transforms (20 + 18 inverse against
    22 + 16: settled at once, a cut after one that could not wait shares its step's product,
    which skips H d's inverse transforms); that is not asserted."""
    problem = NormalProblem(rough(512, seed=1), FLAT, comm, operator="fft")
    convolution = problem.flexibility.convolution
    counts = []

    def counted(index, method):
        def call(*args, **kwargs):
            counts[-1][index] += 1
            return method(*args, **kwargs)
        return call

    monkeypatch.setattr(convolution, "_transform", counted(0, convolution._transform))
    monkeypatch.setattr(convolution, "backward", counted(1, convolution.backward))
    states = []
    for defer in (0.0, CGSettings().defer):
        counts.append([0, 0])
        states.append(solve(problem, "cg", lambda s: s.solve_load(0.01 * problem.topography.nominal_area,
                                                                  rotation=(0.0, 0.0)),
                            settings=CGSettings(defer=defer)))
    at_once, deferred = counts
    assert deferred[0] < at_once[0]
    assert_same_state(*states)
    problem.destroy()


@pytest.mark.parametrize("defer", [-0.5, float("nan"), float("inf")])
def test_bad_defer_is_named(defer):
    with pytest.raises(InputError, match="defer"):
        CGSettings(defer=defer)


def test_cg_on_a_users_mat_settles_every_cut(comm, monkeypatch):
    """A user's Mat has no kernel table, so no near field: the CG (plain preconditioner) takes
    every cut's product at once even where the grid's size would let far fields wait (DEFER_FROM
    1), and reaches the built-in operator's state."""
    import roughcontact.normal.constrained_cg as constrained_cg

    monkeypatch.setattr(constrained_cg, "DEFER_FROM", 1)
    topo = rough(32, seed=3)
    reference = NormalProblem(topo, FLAT, comm, operator="dense")
    settings = CGSettings(preconditioner="none")
    control = lambda s: s.solve_load(0.01 * topo.nominal_area, rotation=(0.0, 0.0))    # noqa: E731
    expected = solve(reference, "cg", control, settings=settings)
    user = reference.operator.convert("aij")
    problem = NormalProblem(topo, FLAT, comm, operator=user)
    assert problem.flexibility.near_field is None
    result = solve(problem, "cg", control, settings=settings, nested=False)
    assert_same_state(expected, result)
    problem.destroy()
    user.destroy()
    reference.destroy()
