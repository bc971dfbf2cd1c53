"""Partial slip of a rough (fractal) contact: the paper's §4.2 properties and §5 results.

A random-midpoint surface (Δ = 2.3, 33 × 33 nodes) between two identical
ν = 0 half-spaces (β = γ = 0, so the Cattaneo analogy is exact), pressed by
P = 100 N with free rotation (the corrective solves keep that rotation
fixed, Eq. 23), swept in Q from 0 to fP.


The corrective solves use the active set (``method="ksp"``), exact on its contact set to
the Krylov tolerance, so the discrete identities hold to round-off; the constrained CG
reaches the same states to its tolerance (tests/test_tangential_large.py).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr

from roughcontact.materials import Interface, Material
from roughcontact.netcdf import write_netcdf
from roughcontact.normal import ActiveSetSolver, NormalProblem
from roughcontact.surfaces import midpoint_surface
from roughcontact.tangential import (
    CattaneoSolver,
    UncoupledApproximationWarning,
    fretting_cycle,
    fretting_dataset,
    incipient_sliding_energy,
    tangential_dataset,
    tangential_sweep,
)
from roughcontact.tangential import model as cattaneo_model_module

EXACT = Interface(Material(20e9, 0.0), Material(20e9, 0.0))
FRICTION = 0.6
LOAD = 100.0


@pytest.fixture(scope="module")
def comm():
    from mpi4py import MPI

    return MPI.COMM_WORLD


@pytest.fixture(scope="module")
def rough(comm):
    """(problem, normal) on a module-wide problem, destroyed collectively at the end."""
    topo = midpoint_surface(5, 2.3, spacing=1e-4, rms_height=1e-5, seed=3)
    problem = NormalProblem(topo, EXACT, comm)
    with ActiveSetSolver(problem) as solver:
        normal = solver.solve_load(LOAD)
    yield problem, normal
    problem.destroy()


@pytest.fixture(scope="module")
def sweep20(rough):
    problem, normal = rough
    return tangential_sweep(problem, normal, FRICTION, steps=20, method="ksp")


def test_normal_state_is_tilted(rough):
    """The fixture exercises Eq. 23's fixed rotation: the free normal solve found θ ≠ 0."""
    _, normal = rough
    assert max(abs(normal.rotation[0]), abs(normal.rotation[1])) > 1e-4


def test_slip_area_grows_linearly_with_q(rough, sweep20):
    """§4.2 (vi): the slip area is the difference of two contact areas, both ∝ load, so ∝ Q.

    Fit over 21 states (Q/fP = 0 … 1): R² ≥ 0.98 (measured 0.993), and the
    slope × fP equals the real contact area A_r within 15 % (measured 1.01;
    0.87–1.02 over six surfaces): A_r ∝ P holds only roughly for a finite
    surface at 5–10 % contact.
    """
    _, normal = rough
    q = sweep20.tangential
    area = np.array([s.slip_area for s in sweep20.states])
    slope, intercept = np.polyfit(q, area, 1)
    residual = area - (slope * q + intercept)
    assert 1.0 - residual.var() / area.var() > 0.98
    assert slope * FRICTION * normal.load == pytest.approx(normal.contact_area, rel=0.15)
    # the stick and slip sets partition the contact set
    for state in sweep20.states:
        assert state.stick_area + state.slip_area == pytest.approx(normal.contact_area, rel=1e-12)


def test_stick_force_rises_then_falls(sweep20):
    """Fig. 10b: Q_slip only grows; Q_stick first carries nearly all of Q, peaks inside, then falls.

    With receding stick sets (checked: no node sticks again) a slipping node
    keeps q = f p, so Q_slip is non-decreasing exactly. Bounds from six
    surfaces: Q_stick/Q ≥ 0.88 at Q = fP/20, peak at Q/fP in 0.45–0.7, and at
    Q = 0.95 fP at most 0.65 of the peak.
    """
    q = sweep20.tangential
    q_stick = np.array([s.stick_force for s in sweep20.states])
    q_slip = np.array([s.slip_force for s in sweep20.states])
    assert sweep20.resticking_nodes == 0
    assert np.all(np.diff(q_slip) >= -1e-9 * q[-1])
    assert q_stick[1] > 0.8 * q[1]
    peak = int(np.argmax(q_stick))
    assert 0.25 < sweep20.states[peak].load_ratio < 0.85
    assert q_stick[-2] < 0.8 * q_stick[peak]
    assert q_stick[-1] == 0.0


def test_centroids_of_shear(rough, sweep20):
    """G_Q(slip) = G_P(slip) (Coulomb: q = f p on the slip set); Eq. 25; G_Q → G_P at fP.

    Each state's centroids are checked against the normal pressures and the
    two normal solutions' own centroids (q = f (p − p*), so
    G_Q = (P G_P − P* G_P*)/(P − P*)), to round-off (1e-9 s).
    """
    _, normal = rough
    s = sweep20.states[0].spacing
    i, j = np.indices(normal.force.shape) * s
    for state in sweep20.states[1:-1]:
        p_slip = normal.force[state.slip]
        g_p_slip = (p_slip @ i[state.slip] / p_slip.sum(), p_slip @ j[state.slip] / p_slip.sum())
        assert np.allclose(state.slip_centroid, g_p_slip, rtol=0.0, atol=1e-9 * s)
        eq25 = ((np.array(state.slip_centroid) * state.slip_force
                 + np.array(state.stick_centroid) * state.stick_force) / (state.slip_force + state.stick_force))
        assert np.allclose(state.centroid, eq25, rtol=0.0, atol=1e-9 * s)
        p, p_star = normal.load, state.corrective_load
        two_solves = ((p * np.array(normal.centroid) - p_star * np.array(state.corrective.centroid))
                      / (p - p_star))
        assert np.allclose(state.centroid, two_solves, rtol=0.0, atol=1e-7 * s)
    assert np.allclose(sweep20.states[-1].centroid, normal.centroid, rtol=0.0, atol=1e-9 * s)


def test_stick_moves_rigidly_and_coulomb_holds(rough, sweep20):
    """Eq. 20: u_x = H q = δx on the stick set; g ≥ 0 on the slip set; 0 ≤ q ≤ f p (Eq. 14a); Σ q = Q.

    The state's u_x is δx + f (g − g*) from the two solves' gaps and approaches (Eq. 24); H q,
    taken here from the flexibility operator, equals it on the whole footprint to the solvers'
    tolerances (inner rtol 1e-11, active-set tol 1e-8), hence 1e-7 of δx.
    """
    problem, _ = rough
    footprint = problem.topography.footprint
    for state in sweep20.states[1:-1]:
        dx = state.tangential_approach
        local = state.traction[footprint][problem.start:problem.stop]
        product = problem.gather(problem.displacement(local))
        np.testing.assert_allclose(state.displacement[footprint], product, rtol=0.0, atol=1e-7 * dx)
        assert np.abs(product[state.stick[footprint]] - dx).max() < 1e-7 * dx
        assert state.slip_distance[state.slip].min(initial=0.0) > -1e-7 * dx
        # the slip is the relative displacement δx − u_x (Eqs. 22–23), u_x from the operator
        assert np.allclose(state.slip_distance[state.slip], dx - product[state.slip[footprint]],
                           rtol=0.0, atol=1e-7 * dx)
        assert state.coulomb_violation < 1e-7
        assert state.stick_force + state.slip_force == pytest.approx(state.tangential, rel=1e-9)


def test_energy_balance_converges_at_second_order(rough, sweep20):
    """W = ∫ Q dδx = U + E_f; the trapezoidal W converges as 1/N².

    Measured max |W − U − E_f| / W(fP) over the sweep: 0.70 %, 0.15 %,
    0.049 % at N = 10, 20, 40 (ratios 4.7 and 3.0: second order, slowed by
    dδx/dQ growing near fP). Bounds: each doubling gains ≥ 2.5, 0.2 % at N = 40.
    """
    problem, normal = rough
    errors = []
    for steps in (10, 20, 40):
        sweep = sweep20 if steps == 20 else tangential_sweep(problem, normal, FRICTION, steps=steps, method="ksp")
        w = sweep.work
        balance = np.array([s.stored_energy + s.frictional_energy for s in sweep.states])
        errors.append(np.abs(w - balance).max() / w[-1])
    assert errors[2] < 2e-3, errors
    assert errors[0] > 2.5 * errors[1] and errors[1] > 2.5 * errors[2], errors


def test_frictional_energy_reaches_eq27_at_incipient_sliding(rough, sweep20):
    """E_f(Q) → E_tot = Σ f² p̄ Δh (Eq. 27) and δx → f (δz − δz_first touch) as Q → fP.

    A corrective solve at Q = (1 − 1e-9) fP (one node still sticks) and the
    limit written from the undeformed gaps (Eq. 27) are independent routes;
    the discrete δx(Q) is linear in the last stage, so they differ by O(1e-9)
    (measured 2e-8 relative), bound 1e-6.
    """
    problem, normal = rough
    limit = sweep20.states[-1]
    with CattaneoSolver(problem, normal, FRICTION, method="ksp") as solver:
        near = solver.solve((1.0 - 1e-9) * FRICTION * normal.load)
    assert 0 < near.stick.sum() <= 2
    assert near.frictional_energy == pytest.approx(limit.frictional_energy, rel=1e-6)
    assert near.frictional_energy == pytest.approx(incipient_sliding_energy(problem, normal, FRICTION), rel=1e-6)
    assert near.tangential_approach == pytest.approx(limit.tangential_approach, rel=1e-6)
    energies = np.array([s.frictional_energy for s in sweep20.states])
    assert np.all(np.diff(energies) > 0.0)


def test_fretting_loop_area_is_the_dissipated_energy(rough):
    """∮ Q dδx over a cycle ±0.5 fP equals Σ f p̄ |Δg| of the nodes slipping back.

    Trapezoidal loop area over 2 × 20 steps, second order (0.24 % measured);
    bound 1 %. Per cycle the dissipation is 4 E_f(Q*) (Masing), checked to round-off.
    """
    problem, normal = rough
    cycle = fretting_cycle(problem, normal, FRICTION, 0.5 * FRICTION * normal.load, steps=20, method="ksp")
    assert cycle.loop_area == pytest.approx(cycle.dissipated_per_cycle, rel=0.01)
    assert cycle.dissipated_per_cycle == pytest.approx(4.0 * cycle.turning_point.frictional_energy, rel=1e-9)
    # after unloading to −Q* the traction is the mirror image of the one at Q*
    n = len(cycle.loading.states)
    assert np.allclose(cycle.traction(2 * n - 1), -cycle.turning_point.traction, rtol=0.0,
                       atol=1e-9 * FRICTION * normal.force.max())
    ds = fretting_dataset(cycle)
    assert ds.attrs["loop_area"] == cycle.loop_area and ds["Q"].attrs["units"] == "N"


def test_direction_rotates_the_vectors_only(rough, sweep20):
    """The γ = 0 kernel is isotropic: Q along (3, 4) gives the same stick/slip state, rotated.

    The state along x comes from a warm-started sweep, this one from a fresh
    solver, so they agree to the solvers' tolerance rather than bit for bit.
    """
    problem, normal = rough
    q = 0.5 * FRICTION * normal.load
    with CattaneoSolver(problem, normal, FRICTION, direction=(3.0, 4.0), method="ksp") as solver:
        state = solver.solve(q)
    along_x = sweep20.states[10]
    assert state.direction == pytest.approx((0.6, 0.8), rel=1e-15)
    assert np.array_equal(state.stick, along_x.stick)
    assert state.tangential_approach == pytest.approx(along_x.tangential_approach, rel=1e-9)
    qx, qy = state.traction_vector
    # two solves from different warm starts: equal to the solver's tolerance (4e-10 measured)
    assert np.abs(np.hypot(qx, qy) - along_x.traction).max() < 1e-8 * along_x.traction.max()
    assert state.approach_vector == pytest.approx((0.6 * state.tangential_approach,
                                                   0.8 * state.tangential_approach), rel=1e-12)


def test_dataset_for_the_figures(comm, rough, sweep20, tmp_path_factory):
    """Figs. 9–12 read from the dataset: Q and Q/fP coordinates, CF units, exactness label; NetCDF round trip."""
    _, normal = rough
    ds = tangential_dataset(sweep20)
    assert ds.sizes["Q"] == 21
    assert ds["Q_over_fP"].values[-1] == pytest.approx(1.0)
    for name in ("stick_area", "slip_area", "stick_force", "slip_force", "centroid_x", "slip_centroid_y",
                 "tangential_approach", "frictional_energy", "work", "traction", "zone"):
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
    assert ds.attrs["cattaneo_model"] == "exact"
    assert ds.attrs["incipient_sliding_energy"] == sweep20.states[-1].frictional_energy
    assert int((ds["zone"].isel(Q=10) == 2).sum()) * sweep20.states[0].spacing ** 2 == pytest.approx(
        float(ds["slip_area"].isel(Q=10)))
    path = tmp_path_factory.getbasetemp() / "tangential.nc" if comm.Get_rank() == 0 else None
    path = comm.bcast(str(path) if path else None, root=0)
    write_netcdf(ds, path, comm)
    with xr.open_dataset(path, engine="h5netcdf") as back:
        assert np.allclose(back["frictional_energy"].values, ds["frictional_energy"].values)
        assert back.attrs["cattaneo_model"] == "exact"


def test_uncoupled_approximation_is_labelled_and_warned_once(comm, monkeypatch):
    """β = 0 but γ ≠ 0 (ν = 0.2): the result is the uncoupled approximation, said once per process."""
    monkeypatch.setattr(cattaneo_model_module, "_warned", set())
    topo = midpoint_surface(4, 2.3, spacing=1e-4, rms_height=1e-5, seed=1)
    problem = NormalProblem(topo, Interface(Material(20e9, 0.2), Material(20e9, 0.2)), comm)
    with ActiveSetSolver(problem) as solver:
        normal = solver.solve_load(10.0)
    with pytest.warns(UncoupledApproximationWarning, match="gamma"):
        first = tangential_sweep(problem, normal, FRICTION, steps=2, method="ksp")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UncoupledApproximationWarning)
        second = tangential_sweep(problem, normal, FRICTION, steps=2, method="ksp")
    problem.destroy()
    assert first.model == second.model == "uncoupled approximation"
    assert tangential_dataset(first, fields=False).attrs["cattaneo_model"] == "uncoupled approximation"
    assert all(s.model == "uncoupled approximation" for s in first.states)
