"""Bad input to the tangential solvers: an InputError naming the parameter, never a wrong number."""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import ActiveSetSolver, NormalProblem
from roughcontact.surfaces import Topography
from roughcontact.tangential import CattaneoSolver, fretting_cycle, fretting_map, tangential_sweep

from conftest import sphere_heights

EXACT = Interface(Material(200e9, 0.0), Material(200e9, 0.0))


@pytest.fixture(scope="module")
def comm():
    from mpi4py import MPI

    return MPI.COMM_WORLD


@pytest.fixture(scope="module")
def sphere(comm):
    s = 2e-6
    topo = Topography(sphere_heights(21, s, 0.01), s)
    problem = NormalProblem(topo, EXACT, comm)
    with ActiveSetSolver(problem) as solver:
        normal = solver.solve_closure((8 * s) ** 2 / 0.01)
    yield problem, normal
    problem.destroy()


@contextmanager
def raises(parameter: str, match: str | None = None):
    """pytest.raises(InputError) that also checks the error names ``parameter``."""
    with pytest.raises(InputError, match=match) as info:
        yield info
    assert info.value.parameter == parameter, info.value


@pytest.mark.parametrize("friction", [0.0, -0.3, float("nan"), float("inf"), "rough", None])
def test_friction_must_be_positive(sphere, friction):
    problem, normal = sphere
    with raises("friction"):
        CattaneoSolver(problem, normal, friction, method="ksp")
    with raises("friction"):
        tangential_sweep(problem, normal, friction, steps=3, method="ksp")


def test_full_sliding_is_refused_with_the_reason(sphere):
    """Q ≥ fP is full sliding: displacements are undetermined (§5.2); the limit is offered instead."""
    problem, normal = sphere
    with CattaneoSolver(problem, normal, 0.4, method="ksp") as solver:
        for q in (0.4 * normal.load, 0.5 * normal.load):
            with raises("tangential", match="undetermined"):
                solver.solve(q)
        with raises("tangential", match=">= 0"):
            solver.solve(-1e-3)
        with raises("tangential"):
            solver.solve(float("nan"))
        # just below fP is fine, and the limit itself is a method
        assert solver.solve(0.4 * normal.load * (1 - 1e-6)).slip_area > 0.0
        assert solver.incipient_sliding().limit
    with raises("tangential", match="undetermined"):
        tangential_sweep(problem, normal, 0.4, tangential=[0.0, 0.4 * normal.load], method="ksp")
    with raises("amplitude", match="undetermined"):
        fretting_cycle(problem, normal, 0.4, 0.4 * normal.load, steps=4, method="ksp")


@pytest.mark.parametrize("direction", [(0.0, 0.0), (np.nan, 1.0), (1.0,), "x", (np.inf, 0.0)])
def test_direction_must_be_a_nonzero_vector(sphere, direction):
    problem, normal = sphere
    with raises("direction"):
        CattaneoSolver(problem, normal, 0.3, direction=direction, method="ksp")


def test_normal_state_must_belong_to_the_problem(comm, sphere):
    problem, normal = sphere
    with ActiveSetSolver(problem) as solver:
        unloaded = solver.solve_load(0.0)
    with raises("normal", match="P must be > 0"):
        CattaneoSolver(problem, unloaded, 0.3, method="ksp")
    other = NormalProblem(Topography(sphere_heights(15, 2e-6, 0.01), 2e-6), EXACT, comm)
    try:
        with raises("normal", match="another problem"):
            CattaneoSolver(other, normal, 0.3, method="ksp")
    finally:
        other.destroy()
    with raises("normal"):
        CattaneoSolver(problem, "not a result", 0.3, method="ksp")
    with raises("normal", match="P must be > 0"):
        fretting_map(problem, unloaded, 0.3, [0.5], method="ksp")
    with raises("normal"):
        fretting_map(problem, "not a result", 0.3, [0.5], method="ksp")


@pytest.mark.parametrize("amplitudes", [[], [0.0, 0.5], [0.5, 1.0], [0.5, 0.3], [np.nan]])
def test_fretting_map_amplitudes(sphere, amplitudes):
    problem, normal = sphere
    with raises("amplitudes"):
        fretting_map(problem, normal, 0.3, amplitudes, method="ksp")


def test_auto_corrective_solver_reads_the_cattaneo_prefix(sphere):
    """method="auto" is resolved before the prefix is chosen: on a small grid it picks the active
    set, which then reads PETSc options under cattaneo_ (not normal_) and takes the ksp options."""
    problem, normal = sphere
    with CattaneoSolver(problem, normal, 0.3, rtol=1e-10, options={"ksp_max_it": 5000}) as solver:
        assert solver.solver.method == "ksp"
        assert solver.solver.method_reason.startswith("auto")
        assert solver.solver.inner.ksp.getOptionsPrefix() == "cattaneo_"
        state = solver.solve(0.1 * normal.load)
    assert "method ksp (auto" in state.corrective.choice
    with CattaneoSolver(problem, normal, 0.3, method="ksp", prefix="mine_") as solver:
        assert solver.solver.inner.ksp.getOptionsPrefix() == "mine_"


def test_options_the_corrective_solver_does_not_take(sphere):
    """An option the resolved method does not take is an InputError naming it, not a TypeError."""
    problem, normal = sphere
    with raises("rtol", match="'cg'.*does not take rtol, prefix"):
        CattaneoSolver(problem, normal, 0.3, method="cg", rtol=1e-9, prefix="x_")
    with raises("nested", match="'ksp' \\(auto"):
        CattaneoSolver(problem, normal, 0.3, nested=False)
    with raises("nested"):
        tangential_sweep(problem, normal, 0.3, steps=2, nested=False)


def test_sweep_and_cycle_arguments(sphere):
    problem, normal = sphere
    with raises("steps"):
        tangential_sweep(problem, normal, 0.3, steps=0, method="ksp")
    with raises("steps"):
        tangential_sweep(problem, normal, 0.3, steps=2.5, method="ksp")
    with raises("steps", match="not both"):
        tangential_sweep(problem, normal, 0.3, steps=3, tangential=[0.0], method="ksp")
    with raises("steps", match="not both"):
        tangential_sweep(problem, normal, 0.3, method="ksp")
    with raises("tangential", match="increasing"):
        tangential_sweep(problem, normal, 0.3, tangential=[0.02 * normal.load, 0.01 * normal.load], method="ksp")
    with raises("tangential", match="empty"):
        tangential_sweep(problem, normal, 0.3, tangential=[], method="ksp")
    with raises("amplitude", match="> 0"):
        fretting_cycle(problem, normal, 0.3, 0.0, steps=4, method="ksp")
    with raises("steps"):
        fretting_cycle(problem, normal, 0.3, 0.1 * normal.load, steps=0, method="ksp")
    with raises("index"):
        fretting_cycle(problem, normal, 0.3, 0.1 * normal.load, steps=2, method="ksp").traction(9)


def test_q_within_round_off_of_fp_is_solved_or_full_sliding(sphere):
    """Q = fP reached through np.linspace meets f times the *solved* P, which differs from the
    imposed P by the load-control tolerance. Just below fP the corrective solve still resolves
    P* = P − Q/f (one node sticks, Coulomb holds); at or above fP, and when the corrective solve
    fails within the load tolerance of fP, the result is the full-sliding limit with its
    message, never a ConvergenceError."""
    from roughcontact.errors import ConvergenceError
    from roughcontact.normal import ActiveSetSettings

    problem, normal = sphere
    f = 0.4
    with ActiveSetSolver(problem) as solver:
        imposed = solver.solve_load(normal.load)       # the same contact under load control
    for q in (f * imposed.load * (1 - 1e-15), f * imposed.load * (1 - 2e-9),
              np.linspace(0.0, f * normal.load, 5)[-1]):
        if q >= f * imposed.load:
            with raises("tangential", match="full sliding"):
                tangential_sweep(problem, imposed, f, tangential=[0.0, q], method="ksp")
            continue
        state = tangential_sweep(problem, imposed, f, tangential=[0.0, q], include_limit=False, method="ksp").states[-1]
        assert state.stick.sum() >= 1 and state.coulomb_violation == 0.0
    with raises("amplitude", match="full sliding"):
        fretting_cycle(problem, imposed, f, f * imposed.load * (1 + 1e-12), steps=2, method="ksp")
    # a corrective solve that cannot converge (one active-set iteration allowed): within the
    # load tolerance of fP it is the full-sliding limit, far from fP the failure it is
    starved = dict(settings=ActiveSetSettings(max_outer=1))
    with raises("tangential", match="load tolerance \\(1e-08\\)") as info:
        tangential_sweep(problem, imposed, f, tangential=[f * imposed.load * (1 - 2e-9)], **starved, method="ksp")
    assert isinstance(info.value.__cause__, ConvergenceError)
    # the band is the corrective solver's own load tolerance
    loose = dict(settings=ActiveSetSettings(max_outer=1, load_tol=1e-6))
    with raises("tangential", match="load tolerance \\(1e-06\\)"):
        tangential_sweep(problem, imposed, f, tangential=[f * imposed.load * (1 - 2e-7)], **loose, method="ksp")
    with pytest.raises(ConvergenceError):
        tangential_sweep(problem, imposed, f, tangential=[f * imposed.load * (1 - 2e-7)], **starved, method="ksp")
    with pytest.raises(ConvergenceError):
        tangential_sweep(problem, imposed, f, tangential=[0.5 * f * imposed.load], **starved, method="ksp")