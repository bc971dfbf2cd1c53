"""Tangential load histories with reversals by the memory rules (Mindlin–Deresiewicz, Jäger).

Checked against three references that do not use the memory rules:
the single-cycle result of :func:`roughcontact.tangential.fretting_cycle`
(the superposition with 2f written out for one cycle), the Hertz closed
forms (Mindlin–Deresiewicz, :mod:`roughcontact.references.cattaneo_mindlin`)
with the memory rules applied to the closed-form virgin curve here, and the
coupled solver at γ = 0, which follows the path increment by increment with
Coulomb's law (Eqs. 14a–b) and knows nothing of memory.
"""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import ActiveSetSolver, NormalProblem
from roughcontact.references import cattaneo_mindlin, hertz
from roughcontact.surfaces import Topography, midpoint_surface
from roughcontact.tangential import fretting_cycle
from roughcontact.tangential.coupled import CoupledTangentialSolver
from roughcontact.tangential.history import tangential_history

from conftest import sphere_heights

EXACT = Interface(Material(200e9, 0.0), Material(200e9, 0.0))    # β = γ = 0
RADIUS, A0, FRICTION = 0.01, 50e-6, 0.5


@pytest.fixture(scope="module")
def comm():
    return MPI.COMM_WORLD


def hertz_problem(comm, a_over_s: int):
    s = A0 / a_over_s
    n = int(2.4 * a_over_s) | 1
    problem = NormalProblem(Topography(sphere_heights(n, s, RADIUS), s), EXACT, comm)
    with ActiveSetSolver(problem) as solver:
        normal = solver.solve_closure(A0**2 / RADIUS)
    return problem, normal


@pytest.fixture(scope="module")
def hertz16(comm):
    problem, normal = hertz_problem(comm, 16)
    yield problem, normal
    problem.destroy()


def ramp(start: float, stop: float, steps: int) -> np.ndarray:
    """``steps`` points from start (excluded) to stop (included)."""
    return start + (stop - start) * np.arange(1, steps + 1) / steps


def test_single_cycle_is_the_fretting_cycle(hertz16):
    """0 → Q* → −Q* → Q*: the same states as fretting_cycle (both superpose monotonic states at the
    same X, each a Krylov solve to rtol 1e-11 from its own warm start: 1e-9 of f max p and of δx), its
    loop energy, 4 E_f(Q*) dissipated per cycle, and the memory wiped out when
    the cycle closes (the state at Q* is the first-loading one again)."""
    problem, normal = hertz16
    steps, amplitude = 8, 0.6 * FRICTION * normal.load
    cycle = fretting_cycle(problem, normal, FRICTION, amplitude, steps, method="ksp")
    loads = np.concatenate([ramp(0, amplitude, steps), ramp(amplitude, -amplitude, 2 * steps),
                            ramp(-amplitude, amplitude, 2 * steps)])
    path = tangential_history(problem, normal, FRICTION, loads, method="ksp")
    # fretting path: loading u_k, unloading Q* − 2u_k, reloading −Q* + 2u_k (k = 0 … N)
    n = steps + 1
    index = np.concatenate([np.arange(n), steps + 2 * np.arange(1, n), 3 * steps + 2 * np.arange(1, n)])
    scale = FRICTION * normal.force.max()
    for i_path, i_cycle in zip(index, np.concatenate([np.arange(n), n + np.arange(1, n), 2 * n + np.arange(1, n)])):
        assert path.tangential[i_path] == pytest.approx(cycle.tangential[i_cycle], rel=1e-12, abs=1e-12 * amplitude)
        assert path.approach[i_path] == pytest.approx(cycle.approach[i_cycle], rel=1e-9, abs=1e-20)
        assert np.abs(path.tractions[i_path] - cycle.traction(i_cycle)).max() < 1e-9 * scale
    per_cycle = path.dissipated[-1] - path.dissipated[steps]
    assert per_cycle == pytest.approx(cycle.dissipated_per_cycle, rel=1e-9)
    assert per_cycle == pytest.approx(4 * cycle.turning_point.frictional_energy, rel=1e-9)
    assert path.memory[-1] == 0 and path.memory[steps + 1] == 1
    assert np.abs(path.tractions[-1] - path.tractions[steps]).max() < 1e-12 * scale
    # the loop's area approaches the dissipation as the path is refined (trapezoidal rule, ~1 % at 16
    # points per branch for this amplitude: dδx/dQ varies most near the turning points)
    assert path.loop_energy(steps, len(loads)) == pytest.approx(per_cycle, rel=0.03)


def test_each_monotonic_state_is_solved_once(hertz16, monkeypatch):
    """The same X = |Q − Q_k|/2 reached on several branches differs in its last bits; it is one
    corrective solve, not one per branch (keyed on the raw float this path took 22). The
    nested history below needs X = j fP/20, j = 0 … 16: 17 states. They nest, so nothing is warned."""
    import warnings

    from roughcontact.tangential.cattaneo import CattaneoSolver

    problem, normal = hertz16
    fp = FRICTION * normal.load
    loads = np.concatenate([ramp(0, 0.6 * fp, 6), ramp(0.6 * fp, -0.2 * fp, 8), ramp(-0.2 * fp, 0.6 * fp, 8),
                            ramp(0.6 * fp, 0.8 * fp, 2), ramp(0.8 * fp, -0.8 * fp, 16), ramp(-0.8 * fp, 0.8 * fp, 16)])
    solved = []
    solve = CattaneoSolver.solve
    monkeypatch.setattr(CattaneoSolver, "solve", lambda self, q: solved.append(q) or solve(self, q))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        path = tangential_history(problem, normal, FRICTION, loads, method="ksp")
    assert len(solved) == 17
    assert np.allclose(np.sort(solved), fp * np.arange(17) / 20, rtol=1e-12, atol=0.0)
    assert path.tangential.size == loads.size + 1


def closed_form_history(loads: np.ndarray, virgin) -> np.ndarray:
    """δx along ``loads`` from the virgin curve δx(Q) by Masing's rules with memory, written
    independently of the module: a stack of turning points, a loop closes when Q passes the
    turning point before the last."""
    turning: list[tuple[float, float]] = []        # (Q, δx) at each remembered reversal
    out, previous, motion = [], (0.0, 0.0), 0.0
    for q in loads:
        move = np.sign(q - previous[0])
        if move and motion and move != motion:
            turning.append(previous)
        motion = move or motion
        while turning:
            q_n = turning[-1][0]
            q_back = turning[-2][0] if len(turning) > 1 else -q_n
            if (q - q_back) * (q_n - q_back) <= 0:        # passed the older turning point
                del turning[-2:]                          # both, or the first and the mirror
            else:
                break
        if turning:
            q_n, d_n = turning[-1]
            d = d_n + np.sign(q - q_n) * 2 * virgin(abs(q - q_n) / 2)
        else:
            d = np.sign(q) * virgin(abs(q))
        out.append(d)
        previous = (q, d)
    return np.array(out)


def test_hertz_history_against_mindlin_deresiewicz(hertz16):
    """A history with nested reversals on Hertz: δx at every point against the Mindlin–Deresiewicz
    closed form under the same memory rules, and the energy of the closed inner loop and of a
    steady cycle against the closed-form loop energy (Johnson §7.3). Measured at a/s = 16: δx within
    0.07 % of the scale f a²/R, the two loop energies within 0.3 %; bounds 0.15 % and 1 %."""
    problem, normal = hertz16
    fp = FRICTION * normal.load
    loads = np.concatenate([ramp(0, 0.6 * fp, 6), ramp(0.6 * fp, -0.2 * fp, 8),   # inner loop …
                            ramp(-0.2 * fp, 0.6 * fp, 8),                          # … closes at 0.6
                            ramp(0.6 * fp, 0.8 * fp, 2),                           # virgin again
                            ramp(0.8 * fp, -0.8 * fp, 16), ramp(-0.8 * fp, 0.8 * fp, 16)])
    path = tangential_history(problem, normal, FRICTION, loads, method="ksp")
    delta, e_star = A0**2 / RADIUS, EXACT.contact_modulus
    p_hertz = hertz.load(delta, RADIUS, e_star)
    # closed forms at the same Q/fP (the discrete P differs from Hertz's by 0.2–0.4 %)

    def virgin(q):
        return cattaneo_mindlin.tangential_approach(delta, RADIUS, e_star, q / fp * FRICTION * p_hertz, FRICTION)

    expected = closed_form_history(np.concatenate([[0.0], loads]), virgin)
    scale = FRICTION * delta
    assert np.abs(path.approach - expected).max() < 0.0015 * scale
    assert list(path.memory[[6, 7, 14, 15, 22, 23]]) == [0, 1, 1, 2, 0, 0]
    inner = path.dissipated[22] - path.dissipated[6]
    assert inner == pytest.approx(cattaneo_mindlin.loop_energy(delta, RADIUS, e_star, 0.4 * FRICTION * p_hertz,
                                                               FRICTION), rel=0.01)
    steady = path.dissipated[-1] - path.dissipated[24]
    assert steady == pytest.approx(cattaneo_mindlin.loop_energy(delta, RADIUS, e_star, 0.8 * FRICTION * p_hertz,
                                                                FRICTION), rel=0.01)


def test_fretting_map_energy_per_cycle(hertz16):
    """Energy per steady cycle against amplitude (the fretting map): 4 E_f(Q*) against the closed form,
    3 % (measured 1.8 % at Q*/fP = 0.3, where the slip annulus is two nodes wide, 0.2–0.4 % above),
    and growing with Q*."""
    problem, normal = hertz16
    fp = FRICTION * normal.load
    delta, e_star = A0**2 / RADIUS, EXACT.contact_modulus
    p_hertz = hertz.load(delta, RADIUS, e_star)
    energies = []
    for ratio in (0.3, 0.5, 0.7, 0.9):
        q_star = ratio * fp
        path = tangential_history(problem, normal, FRICTION, [q_star, -q_star, q_star, -q_star, q_star],
                                  method="ksp")
        first, second = np.diff(path.dissipated[[1, 3, 5]])
        assert first == pytest.approx(second, rel=1e-12)            # a steady cycle from the first
        assert first == pytest.approx(cattaneo_mindlin.loop_energy(delta, RADIUS, e_star,
                                                                   ratio * FRICTION * p_hertz, FRICTION), rel=0.03)
        energies.append(first)
    assert np.all(np.diff(energies) > 0)


@pytest.mark.parametrize("case", ["hertz", "rough"])
def test_memory_rules_match_the_incremental_coulomb_solve(comm, case):
    """At γ = 0 the coupled solver follows the same history increment by increment (Eqs. 14a–b,
    no memory rules); the traction and δx it finds must be the memory rules' to its tolerances
    (Newton 1e-8, Krylov 1e-10): 1e-6 of f max p and of the δx scale."""
    if case == "hertz":
        problem, normal = hertz_problem(comm, 8)
        f = FRICTION
    else:
        topo = midpoint_surface(4, 2.3, spacing=1e-4, rms_height=1e-5, seed=5)
        problem = NormalProblem(topo, Interface(Material(20e9, 0.0), Material(20e9, 0.0)), comm)
        with ActiveSetSolver(problem) as solver:
            normal = solver.solve_load(50.0)
        f = 0.6
    try:
        fp = f * normal.load
        loads = np.concatenate([ramp(0, 0.7 * fp, 4), ramp(0.7 * fp, -0.1 * fp, 4), ramp(-0.1 * fp, 0.4 * fp, 3),
                                ramp(0.4 * fp, -0.5 * fp, 5)])
        path = tangential_history(problem, normal, f, loads, method="ksp")
        coupled = _coupled_path(problem, normal, f, loads)
    finally:
        problem.destroy()
    scale = f * normal.force.max()
    for k, state in enumerate(coupled, start=1):
        assert np.abs(state.traction_x - path.tractions[k]).max() < 1e-6 * scale, k
        assert state.tangential_approach == pytest.approx(path.approach[k], abs=1e-6 * np.abs(path.approach).max())
    assert path.memory.max() >= 2


def _coupled_path(problem, normal, friction, loads):
    with CoupledTangentialSolver(problem, normal, friction) as solver:
        return [solver.solve(float(q)) for q in loads]


def test_bad_input(hertz16):
    problem, normal = hertz16
    fp = FRICTION * normal.load
    with pytest.raises(InputError, match="full sliding"):
        tangential_history(problem, normal, FRICTION, [0.5 * fp, -fp])
    with pytest.raises(InputError, match="loads"):
        tangential_history(problem, normal, FRICTION, [])
    with pytest.raises(InputError, match="loads"):
        tangential_history(problem, normal, FRICTION, [0.1 * fp, float("nan")])
    with pytest.raises(InputError, match="direction"):
        tangential_history(problem, normal, FRICTION, [0.1 * fp], direction=(0, 0))
    path = tangential_history(problem, normal, FRICTION, [0.1 * fp], method="ksp")
    with pytest.raises(InputError, match="start"):
        path.loop_energy(1, 1)
