"""The coupled tangential solver (β = 0, γ ≠ 0, Eqs. 14–20 with the γ terms of Eqs. 15–16).

References it is checked against, none produced by the solver itself:

- the point-force (Cerruti) kernel of Eqs. 15–16 far from the punch, and the
  rigid-punch settlement (2 − ν)/(8 G a) under a tangential force (Johnson,
  Contact Mechanics 1985, §3.8, Eq. 3.92) for its self term;
- at γ = 0 the discrete Cattaneo construction (Eqs. 21–24), an independent
  method (a second normal solve, :mod:`roughcontact.tangential.cattaneo`);
- on Hertz with ν > 0, Mindlin's solution (Johnson §7.2): the Cattaneo
  traction along x with the stick circle c = a (1 − Q/fP)^(1/3) satisfies
  u = δ in the stick zone exactly for any ν (the (4 − 3ν) x², (4 − ν) y²
  and 2ν x y terms of the two Hertz-type distributions cancel), so its
  only error is the slip direction in the annulus, which is not parallel
  to x when ν ≠ 0 (Johnson §7.2; Munisamy, Hills & Nowell, J. Appl. Mech.
  61 (1994) 278–283 solve the coupled problem and find the error small).
  Its compliance is δx = (2 − ν)/(2 (1 − ν)) · f (a² − c²)/R for two
  identical bodies: (1 + γ/2) times Eq. 24's;
- symmetry (q_y odd in x and in y for loading along x on a surface even in
  both), covariance under a 90° rotation, equilibrium (Eq. 19).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from mpi4py import MPI

from roughcontact.errors import ConvergenceError, InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import ActiveSetSolver, NormalProblem
from roughcontact.operators.shear import ShearConvolution, shear_kernels, signed_offsets
from roughcontact.references import cattaneo_mindlin
from roughcontact.surfaces import Topography, midpoint_surface
from roughcontact.tangential import UncoupledApproximationWarning, tangential_dataset, tangential_sweep
from roughcontact.tangential.coupled import CoupledSettings, CoupledTangentialSolver, coupled_sweep

from conftest import sphere_heights

RADIUS = 0.01          # sphere radius R (m)
A0 = 50e-6             # Hertz contact radius a (m)
FRICTION = 0.5
A_OVER_S = 10          # Hertz grid: a / s


def identical(nu: float, modulus: float = 200e9) -> Interface:
    """Two identical bodies: β = 0, γ = ν / (1 − ν)."""
    return Interface(Material(modulus, nu), Material(modulus, nu))


def hertz_problem(comm, nu: float, a_over_s: int = A_OVER_S):
    """A sphere pressed to a = A0 on a grid centred on the apex (odd n)."""
    s = A0 / a_over_s
    n = int(2.4 * a_over_s) | 1
    problem = NormalProblem(Topography(sphere_heights(n, s, RADIUS), s), identical(nu), comm)
    with ActiveSetSolver(problem) as solver:
        normal = solver.solve_closure(A0**2 / RADIUS)
    return problem, normal


def uncoupled(problem, normal, friction, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UncoupledApproximationWarning)
        return tangential_sweep(problem, normal, friction, method="ksp", include_limit=False, **kwargs)


@pytest.fixture(scope="module")
def comm():
    return MPI.COMM_WORLD


@pytest.fixture(scope="module")
def hertz_sweeps(comm):
    """Coupled and uncoupled sweeps Q = k fP / 10 on Hertz for ν = 0, 0.3, 0.5."""
    out = {}
    for nu in (0.0, 0.3, 0.5):
        problem, normal = hertz_problem(comm, nu)
        out[nu] = (problem, normal, coupled_sweep(problem, normal, FRICTION, steps=10),
                   uncoupled(problem, normal, FRICTION, steps=10))
    yield out
    for problem, *_ in out.values():
        problem.destroy()


# ------------------------------------------------------------------ the operator
def test_kernel_far_field_is_cerruti():
    """Far from the punch T → the point-force kernel of Eqs. 15–16, A/(2π) [δ/r + γ r r / r³].

    The punch average changes 1/r by (1 + a²/(6r²)) and the deviatoric part by
    (1 − a²/(2r²)): the relative difference is below (a/r)² (a = s/2).
    The cross term's sign is the one Cerruti's solution gives (+ γ Δx Δy / r³).
    """
    s, compliance, gamma = 1e-4, 3e-11, 0.7
    xx, yy, xy = shear_kernels((40, 40), s, compliance, gamma)
    a = s / 2
    for i, j in ((30, 0), (20, 20), (25, 11), (7, 33)):
        dx, dy = i * s, j * s
        r = math.hypot(dx, dy)
        point = compliance / (2 * math.pi) * np.array([1 / r + gamma * dx**2 / r**3,
                                                       1 / r + gamma * dy**2 / r**3,
                                                       gamma * dx * dy / r**3])
        got = np.array([xx[i, j], yy[i, j], xy[i, j]])
        assert np.abs(got - point).max() <= (a / r) ** 2 * point[0], (i, j, got, point)


def test_kernel_self_term_is_tangential_punch_settlement():
    """T_xx(0) = T_yy(0) = (2 − ν)/(8 G a) for one body on a rigid one (Johnson Eq. 3.92), T_xy(0) = 0."""
    for nu in (0.0, 0.25, 0.5):
        body = Material(70e9, nu)
        interface = Interface(body, Material.rigid())
        s = 2e-4
        xx, yy, xy = shear_kernels((4, 4), s, interface.compliance, interface.composite_poisson)
        expected = (2 - nu) / (8 * body.shear_modulus * s / 2)
        assert xx[0, 0] == pytest.approx(expected, rel=1e-13)
        assert yy[0, 0] == pytest.approx(expected, rel=1e-13)
        assert xy[0, 0] == 0.0 and xy[0, 5 % 4] == 0.0 and xy[3, 0] == 0.0


def test_fft_product_is_the_direct_sum_and_positive_definite():
    """The FFT product equals the direct sum of Eqs. 15–16 over all node pairs (to 1e-12 of the
    largest entry: round-off of the transforms) and T is symmetric positive definite at γ = 1."""
    shape, s, compliance, gamma = (9, 7), 1e-4, 2e-11, 1.0
    tables = shear_kernels(shape, s, compliance, gamma)
    i, j = np.indices(shape).reshape(2, -1)
    xx, yy, xy = signed_offsets(tables, i[:, None] - i[None, :], j[:, None] - j[None, :])
    dense = np.block([[xx, xy], [xy, yy]])
    assert np.allclose(dense, dense.T, rtol=0, atol=0)
    assert np.linalg.eigvalsh(dense).min() > 0.0
    rng = np.random.default_rng(1)
    qx, qy = rng.standard_normal(shape), rng.standard_normal(shape)
    convolution = ShearConvolution(shape, s, compliance, gamma, MPI.COMM_SELF, workers=1)
    ux, uy = convolution.apply(qx, qy)
    expected = dense @ np.concatenate([qx.ravel(), qy.ravel()])
    scale = np.abs(expected).max()
    assert np.abs(np.concatenate([ux.ravel(), uy.ravel()]) - expected).max() < 1e-12 * scale


# ------------------------------------------------------------------ γ = 0: Cattaneo
def test_gamma_zero_reproduces_cattaneo(hertz_sweeps):
    """At γ = 0 the coupled solve is Eqs. 17–18 and must give the Cattaneo states (Eqs. 21–24).

    Both solve linear systems on the same sets to Krylov rtol 1e-10/1e-11 and the
    coupled Newton stops at 1e-8 of the increment: stick sets identical, q and δx
    to 1e-7 (of f max p and of δx), E_f to 1e-6 (summed over the increments), q_y
    exactly 0 (T_xy = 0 at γ = 0).
    """
    _, normal, coupled, cattaneo = hertz_sweeps[0.0]
    f_pmax = FRICTION * normal.force.max()
    for c, u in zip(coupled.states, cattaneo.states):
        assert c.tangential == pytest.approx(u.tangential, rel=1e-9, abs=1e-12 * FRICTION * normal.load)
        assert np.array_equal(c.stick, u.stick)
        assert np.abs(c.traction_x - u.traction).max() < 1e-7 * f_pmax
        assert np.abs(c.traction_y).max() == 0.0
        assert c.tangential_approach == pytest.approx(u.tangential_approach, rel=1e-7, abs=1e-16)
        assert c.frictional_energy == pytest.approx(u.frictional_energy, rel=1e-6, abs=1e-20)
        assert c.approach[1] == 0.0


def test_gamma_zero_rough_reproduces_cattaneo(comm):
    """The same on a tilted rough contact (Δ = 2.3, 17 × 17, free rotation), loaded at 30°."""
    topo = midpoint_surface(4, 2.3, spacing=1e-4, rms_height=1e-5, seed=5)
    problem = NormalProblem(topo, identical(0.0, 20e9), comm)
    try:
        with ActiveSetSolver(problem) as solver:
            normal = solver.solve_load(50.0)
        direction = (math.cos(math.pi / 6), math.sin(math.pi / 6))
        coupled = coupled_sweep(problem, normal, 0.6, steps=8, direction=direction)
        cattaneo = uncoupled(problem, normal, 0.6, steps=8, direction=direction)
        f_pmax = 0.6 * normal.force.max()
        for c, u in zip(coupled.states, cattaneo.states):
            assert np.array_equal(c.stick, u.stick)
            assert np.abs(c.traction - u.traction).max() < 1e-7 * f_pmax
            assert np.abs(c.cross_traction).max() < 1e-7 * f_pmax
            assert c.tangential_approach == pytest.approx(u.tangential_approach, rel=1e-7, abs=1e-16)
    finally:
        problem.destroy()


# ------------------------------------------------------------------ Hertz, ν > 0: Mindlin
# measured at a/s = 10, Q/fP = 0.1–0.9: δx / ((1 + γ/2) δx_uncoupled) − 1 within 0.09 % (ν = 0.3) and
# 0.32 % (ν = 0.5), E_f / ((1 + γ/2) E_f uncoupled) − 1 within 0.43 % and 1.6 %; against the closed form
# the discretisation adds its own error (≤ 1 %, largest at Q/fP = 0.1 where δx spans few rings);
# max |q_y| / (f max p) from 0.9 % to 4.5 % (ν = 0.3) and 1.8 % to 8.6 % (ν = 0.5). Bounds about twice.
MINDLIN_TOLERANCE = {0.3: 0.002, 0.5: 0.0065}
ENERGY_TOLERANCE = {0.3: 0.009, 0.5: 0.032}


@pytest.mark.parametrize("nu", [0.3, 0.5])
def test_hertz_coupled_follows_mindlin(hertz_sweeps, nu):
    """Hertz with ν > 0: the compliance is Mindlin's, (2 − ν)/(2(1 − ν)) times Eq. 24's, the stick
    zone stays Mindlin's circle to a ring of nodes, and the coupling adds a small q_y."""
    problem, normal, coupled, cattaneo = hertz_sweeps[nu]
    gamma = nu / (1 - nu)
    factor = (2 - nu) / (2 * (1 - nu))
    assert 1 + gamma / 2 == pytest.approx(factor, rel=1e-14)
    delta, e_star = A0**2 / RADIUS, problem.interface.contact_modulus
    s = problem.topography.spacing
    ring = 2 * math.pi * A0 / s                 # nodes on the contact circle
    for c, u in zip(coupled.states[1:], cattaneo.states[1:]):
        assert c.tangential_approach / (factor * u.tangential_approach) - 1 == pytest.approx(
            0.0, abs=MINDLIN_TOLERANCE[nu])
        closed = factor * cattaneo_mindlin.tangential_approach(
            delta, RADIUS, e_star, c.load_ratio * FRICTION * _hertz_load(problem), FRICTION)
        assert c.tangential_approach / closed - 1 == pytest.approx(0.0, abs=0.02)
        assert c.frictional_energy / (factor * u.frictional_energy) - 1 == pytest.approx(
            0.0, abs=ENERGY_TOLERANCE[nu])
        assert abs(c.stick.sum() - u.stick.sum()) <= 0.25 * ring
        # the coupling: q_y ≠ 0, small next to f p0 (Mindlin's approximation is close)
        cross = np.abs(c.traction_y).max() / (FRICTION * normal.force.max())
        assert 0.005 < cross < 0.12 * gamma
    # the cross shear grows with γ: compare the two ν at Q/fP = 0.5
    if nu == 0.5:
        low = hertz_sweeps[0.3][2].states[5]
        assert np.abs(coupled.states[5].traction_y).max() > np.abs(low.traction_y).max()


def _hertz_load(problem) -> float:
    from roughcontact.references import hertz

    return hertz.load(A0**2 / RADIUS, RADIUS, problem.interface.contact_modulus)


@pytest.mark.parametrize("nu", [0.3, 0.5])
def test_hertz_symmetry(hertz_sweeps, nu):
    """Loading along x on a surface even in x and y: q_x even and q_y odd in each (so Σ q_y = 0,
    Q_y = 0 by Eq. 19), δy = 0, stick set symmetric. To 1e-7 f max p (Newton tol 1e-8)."""
    _, normal, coupled, _ = hertz_sweeps[nu]
    scale = FRICTION * normal.force.max()
    for c in coupled.states[1:]:
        qx, qy = c.traction_x, c.traction_y
        assert np.abs(qx - qx[::-1, :]).max() < 1e-7 * scale
        assert np.abs(qx - qx[:, ::-1]).max() < 1e-7 * scale
        assert np.abs(qy + qy[::-1, :]).max() < 1e-7 * scale
        assert np.abs(qy + qy[:, ::-1]).max() < 1e-7 * scale
        assert np.array_equal(c.stick, c.stick[::-1, :]) and np.array_equal(c.stick, c.stick[:, ::-1])
        assert abs(qy.sum()) < 1e-9 * c.tangential
        assert abs(c.approach[1]) < 1e-7 * c.approach[0]


def test_rotation_covariance(comm, hertz_sweeps):
    """Loading along y on the same (square-symmetric) contact is loading along x transposed:
    the operator is a rotation-invariant tensor, so q^(y)_y = (q^(x)_x)ᵀ, q^(y)_x = (q^(x)_y)ᵀ.
    The same load path (the coupled solution depends on it), to 1e-7 f max p (Newton tol 1e-8)."""
    problem, normal, along_x, _ = hertz_sweeps[0.3]
    along_y = coupled_sweep(problem, normal, FRICTION, tangential=along_x.tangential[:7], direction=(0.0, 2.0))
    scale = FRICTION * normal.force.max()
    for x_state, y_state in zip(along_x.states, along_y.states):
        assert np.abs(y_state.traction_y - x_state.traction_x.T).max() < 1e-7 * scale
        assert np.abs(y_state.traction_x - x_state.traction_y.T).max() < 1e-7 * scale
        assert y_state.approach[1] == pytest.approx(x_state.approach[0], rel=1e-7, abs=1e-18)


def test_rough_coupled_satisfies_coulomb_and_rigid_stick(comm):
    """A tilted rough contact (Δ = 2.3, 17 × 17) at ν = 0.3, Q at 30°: Σ q = Q e (Eq. 19),
    |q| ≤ f p (Eq. 14a), u = δ on the stick set (Eq. 20) and, on the slip set, q = f p s/|s| with
    s the slip increment of the last step (Eq. 14b). u is recomputed here by the direct sum of
    Eqs. 15–16; tolerances 1e-6 of the step's displacement scale (Newton tol 1e-8, Krylov 1e-10)."""
    topo = midpoint_surface(4, 2.3, spacing=1e-4, rms_height=1e-5, seed=5)
    problem = NormalProblem(topo, identical(0.3, 20e9), comm)
    try:
        with ActiveSetSolver(problem) as solver:
            normal = solver.solve_load(50.0)
        direction = np.array([math.cos(math.pi / 6), math.sin(math.pi / 6)])
        f = 0.6
        sweep = coupled_sweep(problem, normal, f, steps=6, direction=direction)
    finally:
        problem.destroy()
    gamma = problem.interface.composite_poisson
    tables = shear_kernels(topo.shape, topo.spacing, problem.interface.compliance, gamma)
    i, j = np.indices(topo.shape).reshape(2, -1)
    xx, yy, xy = signed_offsets(tables, i[:, None] - i[None, :], j[:, None] - j[None, :])
    dense = np.block([[xx, xy], [xy, yy]])
    n = i.size

    def displacement(state):
        u = dense @ np.concatenate([state.traction_x.ravel(), state.traction_y.ravel()])
        return u[:n].reshape(topo.shape), u[n:].reshape(topo.shape)

    p = normal.force
    for k, (previous, state) in enumerate(zip(sweep.states[:-1], sweep.states[1:]), start=1):
        q = np.stack([state.traction_x, state.traction_y])
        assert q.sum(axis=(1, 2)) == pytest.approx(state.tangential * direction, abs=1e-8 * f * normal.load)
        assert state.tangential == pytest.approx(k * f * normal.load / 6, rel=1e-8)
        size = np.hypot(*q)
        assert (size - f * p)[state.stick | state.slip].max() <= 1e-8 * f * p.max()
        ux, uy = displacement(state)
        ux0, uy0 = displacement(previous)
        delta = np.subtract(state.approach, previous.approach)
        slip = np.stack([delta[0] - (ux - ux0), delta[1] - (uy - uy0)])
        scale = np.abs(delta).max()
        assert np.abs(np.stack([state.approach[0] - ux, state.approach[1] - uy])[:, state.stick]).max() \
            < 1e-6 * abs(state.approach[0])
        s = slip[:, state.slip]
        s_norm = np.hypot(*s)
        moving = s_norm > 1e-6 * scale
        aligned = f * p[state.slip] * s / np.where(s_norm > 0, s_norm, 1.0) - q[:, state.slip]
        assert np.abs(aligned[:, moving]).max() < 1e-5 * f * p.max()
        assert state.frictional_energy >= previous.frictional_energy


# ------------------------------------------------------------------ bad input and failure
def test_bad_input(comm, hertz_sweeps):
    problem, normal, _, _ = hertz_sweeps[0.3]
    with pytest.raises(InputError, match="direction"):
        CoupledTangentialSolver(problem, normal, FRICTION, direction=(0.0, 0.0))
    with pytest.raises(InputError, match="friction"):
        CoupledTangentialSolver(problem, normal, 0.0)
    with CoupledTangentialSolver(problem, normal, FRICTION) as solver:
        with pytest.raises(InputError, match="full sliding"):
            solver.solve(FRICTION * normal.load)
        with pytest.raises(InputError, match="full sliding"):
            solver.solve(-1.5 * FRICTION * normal.load)
        with pytest.raises(InputError, match="tangential"):
            solver.solve(float("nan"))
    with pytest.raises(InputError, match="increasing"):
        coupled_sweep(problem, normal, FRICTION, tangential=[0.2, 0.1])
    with pytest.raises(InputError, match="steps"):
        coupled_sweep(problem, normal, FRICTION, steps=4, tangential=[0.1])
    for bad in ({"tol": 0.0}, {"max_iterations": 0}, {"rtol": 2.0}):
        with pytest.raises(InputError):
            CoupledSettings(**bad)


@pytest.mark.parametrize("interface, word", [
    (Interface(Material(200e9, -0.2), Material(200e9, -0.2)), "nu"),        # ν outside [0, 0.5]
    (Interface(Material(200e9, 0.3), Material(70e9, 0.33)), "beta"),        # dissimilar: β ≠ 0
])
def test_interface_outside_the_solver(comm, interface, word):
    s = A0 / 4
    problem = NormalProblem(Topography(sphere_heights(9, s, RADIUS), s), interface, comm)
    try:
        with ActiveSetSolver(problem) as solver:
            normal = solver.solve_closure(A0**2 / RADIUS / 4)
        with pytest.raises(InputError, match=word):
            CoupledTangentialSolver(problem, normal, FRICTION)
    finally:
        problem.destroy()


def test_failure_raises(hertz_sweeps):
    """A single Newton iteration cannot resolve a large increment with set changes: ConvergenceError."""
    problem, normal, _, _ = hertz_sweeps[0.5]
    with CoupledTangentialSolver(problem, normal, FRICTION, settings=CoupledSettings(max_iterations=1)) as solver:
        with pytest.raises(ConvergenceError, match="COUPLED_MAX_ITERATIONS"):
            solver.solve(0.8 * FRICTION * normal.load)


def test_sweep_reads_as_a_tangential_sweep(hertz_sweeps):
    """W = ∫ Q dδx of the coupled sweep from its own states, and its model label."""
    _, _, coupled, _ = hertz_sweeps[0.3]
    assert coupled.model == "coupled"
    q, d = coupled.tangential, coupled.approach
    assert coupled.work[-1] == pytest.approx(float(np.sum(0.5 * (q[1:] + q[:-1]) * np.diff(d))), rel=1e-12)
    with pytest.raises(InputError, match="dataset"):
        tangential_dataset(coupled)
