"""Corrective solves on the actual contact set (roughcontact.tangential.contact_set).

The part problem's products go through the explicit H_CC of the dense operator
(Flexibility.explicit_products); its solutions are confirmed on the whole
footprint. Exactness (β = γ = 0): two bodies with ν = 0.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from mpi4py import MPI

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import CGSettings, NormalProblem, make_solver
from roughcontact.surfaces import Topography, fourier_surface
from roughcontact.tangential import CattaneoSolver, tangential_sweep
from roughcontact.tangential.contact_set import ContactSetSolver, contact_set_pays

EXACT = Interface(Material(2.0, 0.0), Material(2.0, 0.0))      # E* = 1, β = γ = 0
FRICTION = 0.5
# double precision to a tolerance far below the one a sweep uses, so that two solves of one
# problem by different paths agree to what the tolerance leaves (measured differences: 1e-7 of
# the largest force at tol 1e-8)
TIGHT = CGSettings(tol=1e-12, precision="double")


def surface(n: int) -> Topography:
    s = 1.0 / n
    return fourier_surface(n, s, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8 * s, periodic=False, seed=6)


def light_contact(comm, n: int = 96, load: float = 0.002):
    """A problem and its solution at a load light enough that the contact set's products pay."""
    problem = NormalProblem(surface(n), EXACT, comm, operator="fft")
    with make_solver(problem, "cg", settings=TIGHT) as solver:
        normal = solver.solve_load(load)
    assert contact_set_pays(problem, normal.contact)
    return problem, normal


FOOTPRINTS = {
    "scattered 3 %": lambda shape, rng: rng.random(shape) < 0.03,
    "scattered 10 %": lambda shape, rng: rng.random(shape) < 0.1,
    # every node in the first quarter of the rows: on two ranks the second owns none of them
    "first rows": lambda shape, rng: (np.arange(shape[0])[:, None] < shape[0] // 4) & (rng.random(shape) < 0.3),
}


@pytest.mark.parametrize("name", FOOTPRINTS)
def test_explicit_products_equal_the_fft_products(comm, name):
    """On a footprint that is a small part of its grid the dense operator's products go through
    its matrix; they equal the FFT operator's double products to 1e-13 of their largest value in
    double (both sum the same Eq. 10 entries, in another order; the FFT's own error is 1e-15) and
    within the float32 dot's bound in single: H and x rounded to float32 and N terms summed,
    (N + 2) 2⁻²⁴ relative to Σ|H||x| = H x (H > 0, x > 0). Measured on the 513² sweep's
    3 731 contact nodes: 1.3e-6 of the largest value."""
    topo = surface(64)
    rng = np.random.default_rng(3)
    footprint = FOOTPRINTS[name](topo.shape, rng)
    part = topo.with_footprint(footprint)
    dense = NormalProblem(part, EXACT, comm, operator="dense")
    fft = NormalProblem(part, EXACT, comm, operator="fft")
    assert dense.flexibility.explicit_products and not dense.flexibility.holds
    assert not fft.flexibility.explicit_products
    x = rng.random(dense.local_size)
    exact = fft.displacement(x)
    scale = comm.allreduce(float(np.abs(exact).max(initial=0.0)), op=MPI.MAX)     # a rank may own none
    np.testing.assert_allclose(dense.displacement(x), exact, rtol=0, atol=1e-13 * scale)
    single = dense.displacement(x, single=True)
    assert np.all(np.abs(single - exact) <= (dense.size + 2) * 2.0**-24 * np.abs(exact))
    nodes = np.flatnonzero(rng.random(dense.local_size) < 0.5)
    np.testing.assert_allclose(dense.displacement_at(x[nodes], nodes), fft.displacement_at(x[nodes], nodes),
                               rtol=0, atol=1e-13 * scale)
    dense.destroy()
    fft.destroy()


def test_a_whole_grid_keeps_the_fft_products(comm):
    """A dense operator on a whole grid keeps the FFT's products, even an 8² grid, whose N² is
    64 nx ny; so does a footprint of more than an eighth of its grid."""
    small = Topography(np.random.default_rng(2).random((8, 8)) * 1e-3, 1.0 / 8)
    for topo in (small, surface(33), surface(32).with_footprint(np.repeat(np.arange(32)[:, None] < 5, 32, axis=1))):
        problem = NormalProblem(topo, EXACT, comm, operator="dense")
        assert not problem.flexibility.explicit_products and problem.flexibility.holds
        problem.destroy()


@pytest.mark.parametrize("rotation", [(0.0, 0.0), (0.3, -0.2)])
def test_the_part_problem_is_the_whole_one_on_the_contact_set(comm, rotation):
    """The two problems' vectors map onto each other (values on C, zero off it), and the part's
    rigid motion shifted by ``_shift`` gives the whole problem's interpenetration on C (Eq. 7:
    rotations about each footprint's centroid, the gap from each one's highest node) to round-off
    of the heights (1e-12 of their range). The contact set lies in the first rows: on two ranks
    the second owns none of it."""
    problem, normal = light_contact(comm)
    first_rows = np.arange(problem.topography.shape[0])[:, None] < problem.topography.shape[0] // 4
    contact = normal.contact & first_rows
    assert contact.any()
    with ContactSetSolver(problem, replace(normal, contact=contact), make_solver(problem, "cg")) as solver:
        layout = problem.flexibility.layout
        mine = contact[layout.rows[0]:layout.rows[1]][layout.local_mask]    # C on this rank's nodes
        values = np.arange(1.0, problem.local_size + 1.0)
        part = solver._to_part(values)
        np.testing.assert_array_equal(part, values[mine])
        np.testing.assert_array_equal(solver._to_whole(part), np.where(mine, values, 0.0))
        slope = rotation[0] * problem.height_range / problem.extent, rotation[1] * problem.height_range / problem.extent
        rigid = np.array([0.7 * problem.height_range, *slope])
        shifted = rigid + np.array([solver._shift(slope), 0.0, 0.0])
        np.testing.assert_allclose(solver.part.interpenetration(shifted), problem.interpenetration(rigid)[mine],
                                   rtol=0, atol=1e-12 * problem.height_range)
    problem.destroy()


def test_the_sweep_on_the_contact_set_equals_the_whole_sweep(comm):
    """Stick sets equal node for node, tractions and slips to 1e-9 of their largest value, the
    tangential approach to 1e-9: the restricted and the whole corrective solves are solves of one
    problem to a tolerance of 1e-12, and every restricted one went through the contact set."""
    problem, normal = light_contact(comm)
    whole = tangential_sweep(problem, normal, FRICTION, steps=6, method="cg", settings=TIGHT, restrict=False)
    part = tangential_sweep(problem, normal, FRICTION, steps=6, method="cg", settings=TIGHT)
    scale = FRICTION * normal.force.max()
    for a, b in zip(whole.states[1:-1], part.states[1:-1]):
        assert "iterations on the contact set" in b.corrective.choice
        assert b.corrective.choice.endswith("then 1 on the whole footprint")       # confirmed at once
        assert "on the contact set" not in a.corrective.choice
        np.testing.assert_array_equal(b.stick, a.stick)
        np.testing.assert_allclose(b.traction, a.traction, rtol=0, atol=1e-9 * scale)
        assert b.tangential_approach == pytest.approx(a.tangential_approach, rel=1e-9)
        gap_scale = np.nanmax(np.abs(a.slip_distance))
        np.testing.assert_allclose(b.slip_distance, a.slip_distance, rtol=0, atol=1e-9 * gap_scale)
        assert b.corrective.load == pytest.approx(a.corrective.load, rel=1e-12)
        assert b.corrective.closure == pytest.approx(a.corrective.closure, rel=1e-9)
    assert part.resticking_nodes == 0
    problem.destroy()


def test_a_node_off_the_contact_set_is_found_on_the_whole_footprint(comm):
    """Given a contact set without its ten most loaded nodes, which stick at a small Q, the part
    solve cannot reach them: the whole problem's solver, started from it, goes on until the whole
    footprint's conditions hold, and the answer is the whole solve's (same contact set, forces to
    1e-9 of the largest), in more than the one confirming iteration."""
    problem, normal = light_contact(comm)
    force = normal.force[normal.contact]
    cut = np.sort(force)[-10]
    shrunk = replace(normal, contact=normal.contact & (normal.force < cut))
    corrective_load = normal.load * 0.9
    with make_solver(problem, "cg", settings=TIGHT) as reference:
        reference.warm_start(normal)
        expected = reference.solve_load(corrective_load, rotation=normal.rotation)
    assert np.all(expected.contact[normal.contact & ~shrunk.contact])   # the dropped nodes stick
    with ContactSetSolver(problem, shrunk, make_solver(problem, "cg", settings=TIGHT)) as solver:
        solver.warm_start(normal)
        result = solver.solve_load(corrective_load, rotation=normal.rotation)
    np.testing.assert_array_equal(result.contact, expected.contact)
    np.testing.assert_allclose(result.force, expected.force, rtol=0, atol=1e-9 * normal.force.max())
    assert "iterations on the contact set" in result.choice
    confirming = int(result.choice.rsplit("then ", 1)[1].split()[0])
    assert confirming > 1
    problem.destroy()


def test_restrict_must_be_a_bool(comm):
    problem, normal = light_contact(comm, n=48, load=0.004)
    with pytest.raises(InputError, match="restrict"):
        CattaneoSolver(problem, normal, FRICTION, method="cg", restrict="yes")
    problem.destroy()
