"""The balancing coarse space of the settled contact set (roughcontact/operators/balancing.py).

Its W is C Z, the circulant of the Fourier preconditioner applied by the
preconditioner's own transform with the symbol inverted: for nodes closer than
half C's period C is H, so on a set inside such a window the product must be the
Eq. 10 operator's. The balancing form must be symmetric positive definite and
exact on the coarse space (P W = Z), whatever W is. In a solve it changes the
path, not the state.
"""
from __future__ import annotations

import logging

import numpy as np
import pytest
from mpi4py import MPI

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import CGSettings, NormalProblem, make_solver
from roughcontact.operators.balancing import BALANCING_FROM, BalancingSpace
from roughcontact.operators.extension import EXTENSION_FROM
from roughcontact.operators.flexibility import Flexibility
from roughcontact.surfaces import Topography, fourier_surface

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
FLAT = Interface(Material(1.0, 0.0))
SPACING = 1e-4


def test_the_circulant_is_the_operator_within_half_its_period():
    """[C v]_S against H v on S (the padded Eq. 10 product) for a random set inside a 14 × 14
    window of a 24² grid, whose period (40) is more than twice the window: every pair of nodes is
    closer than half the period, so C_SS = H_SS. Both in double precision: round-off of the two
    transforms, 1e-12 of the largest value."""
    n = 24
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        assert min(flex.preconditioner.convolution.lengths) >= 2 * 14
        rng = np.random.default_rng(5)
        window = np.zeros((n, n), dtype=bool)
        window[4:18, 6:20] = rng.random((14, 14)) < 0.4
        nodes = np.flatnonzero(window)
        values = rng.standard_normal(nodes.size)
        field = np.zeros(n * n)
        field[nodes] = values
        expected = flex.product(field)[nodes]
        with flex.preconditioner.circulant() as circulant:
            got = circulant.apply_nodes(values, nodes)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    finally:
        flex.destroy()


def test_the_symbol_comes_back_after_the_circulant():
    """Inside the block the single-precision product is C's (the double one to float32's 1e-5 of
    the largest value), not C⁻¹'s; after it a preconditioner product is what it was, bit for bit."""
    n = 24
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        nodes = np.arange(0, n * n, 3)
        values = np.random.default_rng(1).standard_normal(nodes.size)
        before = flex.precondition_nodes(values, nodes, single=True)
        with flex.preconditioner.circulant() as circulant:
            double = circulant.apply_nodes(values, nodes)
            single = circulant.apply_nodes(values, nodes, single=True)
        scale = np.abs(double).max()
        np.testing.assert_allclose(single, double, rtol=0, atol=1e-5 * scale)
        assert np.abs(before - double).max() > 0.5 * scale          # C⁻¹ and C are far apart
        np.testing.assert_array_equal(flex.precondition_nodes(values, nodes, single=True), before)
    finally:
        flex.destroy()


def balanced_reference(flex, space, nodes, made_nodes, n, parts):
    """P as a dense matrix on the free set ``nodes``, from its definition: Z the nodes of the set
    in each block that held nodes when the space was made (``made_nodes``), W's rows there and
    zero rows for the nodes that entered since, E = (Zᵀ W + Wᵀ Z) / 2 with a unit diagonal for a
    block none of whose nodes is left, M the dense preconditioner on the set."""
    rows, cols = np.divmod(nodes, n)
    block = (rows // (n // parts)) * parts + cols // (n // parts)
    made_rows, made_cols = np.divmod(made_nodes, n)
    present = np.unique((made_rows // (n // parts)) * parts + made_cols // (n // parts))
    kept = np.isin(nodes, made_nodes)
    Z = np.zeros((nodes.size, present.size))
    Z[kept, np.searchsorted(present, block[kept])] = 1.0
    W = np.zeros((nodes.size, present.size))
    W[kept] = space.W[np.searchsorted(made_nodes, nodes[kept])]
    E = Z.T @ W
    E = 0.5 * (E + E.T)
    empty = ~Z.any(axis=0)
    E[empty, :] = E[:, empty] = 0.0
    E[empty, empty] = 1.0
    M = np.array([flex.precondition_nodes(e, nodes) for e in np.eye(nodes.size)]).T
    Ei = np.linalg.inv(E)
    eye = np.eye(nodes.size)
    return Z @ Ei @ Z.T + (eye - Z @ Ei @ W.T) @ M @ (eye - W @ Ei @ Z.T), kept


def test_the_form_on_a_set_that_moved_is_its_definition():
    """After the set changed (every node of one block left, a few others left, new nodes entered)
    P is the balancing form with Z and W on the nodes kept, zero rows for the new ones and E
    taken again on the set (:func:`balanced_reference`, W's values taken from the space, whose
    product the first test checks): to float32's 1e-5 (W is float32); it is symmetric positive
    definite."""
    n, parts = 32, 2
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        rng = np.random.default_rng(11)
        members = rng.random(n * n) < 0.1
        made_nodes = np.flatnonzero(members)
        space = BalancingSpace(flex.preconditioner, flex.layout, MPI.COMM_SELF, parts=parts)
        space.make(made_nodes, single=False)
        assert space.count == 4
        now = members.copy()
        grid = now.reshape(n, n)
        grid[:16, :16] = False                                       # block 0 empties
        now[made_nodes[rng.random(made_nodes.size) < 0.2]] = False   # a fifth of the rest leave
        entering = np.flatnonzero(~members & (rng.random(n * n) < 0.03))
        now[entering] = True
        nodes = np.flatnonzero(now)

        def precondition(values):
            return flex.precondition_nodes(values, nodes)

        dense = np.array([space.apply(e, nodes, precondition) for e in np.eye(nodes.size)]).T
        reference, kept = balanced_reference(flex, space, nodes, made_nodes, n, parts)
        scale = np.abs(reference).max()
        np.testing.assert_allclose(dense, reference, rtol=0, atol=1e-5 * scale)
        assert np.abs(dense - dense.T).max() <= 1e-5 * scale
        assert np.linalg.eigvalsh(0.5 * (dense + dense.T))[0] > 0.0
        assert (~kept).sum() == entering.size > 0                     # the set really took new nodes
    finally:
        flex.destroy()


@pytest.mark.parametrize("where", ["everywhere", "first rows"])
def test_the_space_is_the_same_on_any_rank_count(comm, where):
    """A space made on this communicator's slabs (the nodes of each rank, the blocks counted over
    all) applies P as the same space made on one rank over the whole set: the blocks come from the
    global rows. With the set on the first rows only, a second rank holds none of it. Tolerance:
    float32 W, 1e-5 of the largest value."""
    n = 32
    rng = np.random.default_rng(4)
    members = rng.random(n * n) < 0.15
    if where == "first rows":
        members.reshape(n, n)[8:] = False
    g = rng.standard_normal(n * n)
    spread = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, comm, kind="fft")
    whole = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        r0, r1 = spread.layout.rows
        local = np.flatnonzero(members[r0 * n:r1 * n])
        mine = BalancingSpace(spread.preconditioner, spread.layout, comm, parts=2)
        mine.make(local, single=False)
        z = mine.apply(g[r0 * n:r1 * n][local], local, lambda v: spread.precondition_nodes(v, local))
        every = np.flatnonzero(members)
        one = BalancingSpace(whole.preconditioner, whole.layout, MPI.COMM_SELF, parts=2)
        one.make(every, single=False)
        expected = one.apply(g[every], every, lambda v: whole.precondition_nodes(v, every))
        assert mine.count == one.count
        at = np.searchsorted(every, r0 * n + local)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(z, expected[at], rtol=0, atol=1e-5 * scale)
    finally:
        spread.destroy()
        whole.destroy()


@pytest.mark.parametrize("density", [0.05, 0.3])
def test_the_balancing_form_is_symmetric_positive_definite_and_exact_on_the_coarse_space(density):
    """P = Z E⁻¹ Zᵀ + (I − Z E⁻¹ Wᵀ) M (I − W E⁻¹ Zᵀ) as a dense matrix on a random set of 32²
    (blocks of 16, four columns of Z): symmetric, positive definite, and P W = Z, the identity the
    form is built on (E = Zᵀ W). W and the products with it are float32 (the space keeps W in
    single precision): 1e-5 of the largest entry."""
    n = 32
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        nodes = np.flatnonzero(np.random.default_rng(7).random(n * n) < density)
        space = BalancingSpace(flex.preconditioner, flex.layout, MPI.COMM_SELF, parts=2)
        space.make(nodes, single=False)
        assert space.count == 4

        def precondition(values):
            return flex.precondition_nodes(values, nodes)

        columns = [space.apply(e, nodes, precondition) for e in np.eye(nodes.size)]
        dense = np.array(columns).T
        scale = np.abs(dense).max()
        assert np.abs(dense - dense.T).max() <= 1e-5 * scale
        assert np.linalg.eigvalsh(0.5 * (dense + dense.T))[0] > 0.0
        rows, cols = np.divmod(nodes, n)
        block = (rows // 16) * 2 + cols // 16
        for j in range(4):
            z = (block == j).astype(float)
            np.testing.assert_allclose(space.apply(space.W[:, j].astype(float), nodes, precondition), z,
                                       rtol=0, atol=1e-5)
    finally:
        flex.destroy()


def test_a_solve_with_the_coarse_space_reaches_the_same_state_on_any_rank_count(comm, caplog, monkeypatch):
    """The large-grid scene's kind of surface at 128² (about 2 % of the nodes in contact) with the
    coarse space from the first grid up: the trace shows it made once on the fine level, the
    directions go through it, and the state is the one without it to 1e-6 of the largest force
    (the CG's tolerance of 1e-8 times the condition of H on the set, test_normal_cg.py), on any
    rank count."""
    s = 1.0 / 128
    surface = fourier_surface(128, s, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                              short_cutoff_wavelength=8 * s, periodic=False, seed=1)
    problem = NormalProblem(surface, FLAT, comm, operator="fft")
    try:
        load = 0.01 * problem.topography.nominal_area

        def solve(settings):
            with make_solver(problem, "cg", settings=settings) as solver:
                return solver.solve_load(load, rotation=(0.0, 0.0))

        without = solve(CGSettings(balancing_from=None))
        applied = []
        original = BalancingSpace.apply

        def counted(self, *args):
            applied.append(self.count)
            return original(self, *args)

        monkeypatch.setattr(BalancingSpace, "apply", counted)
        with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
            balanced = solve(CGSettings(balancing_from=1))
        nodes = problem.size
    finally:
        problem.destroy()
    made = [record.cg_step["nodes"] for record in caplog.records
            if hasattr(record, "cg_step") and "coarse space" in record.cg_step["restart"]]
    assert made.count(nodes) == 1                       # each rank's trace: made once on the fine level
    assert applied and min(applied) >= 1                # and the directions went through it
    assert without.contact_fraction < 0.25
    scale = without.force.max()
    np.testing.assert_allclose(balanced.force, without.force, rtol=0, atol=1e-6 * scale)
    assert balanced.residual <= CGSettings().tol


@pytest.mark.parametrize("name, default, documented", [("balancing_from", BALANCING_FROM, 4096 * 4096),
                                                       ("extension_from", EXTENSION_FROM, 16 * 16)])
def test_the_levels_that_take_a_part_of_the_preconditioner_are_checked(name, default, documented):
    """The coarse space's and the extension's levels (operators/balancing.py, operators/extension.py):
    None or a count of nodes, each bad value named; the defaults 4096² and 16²."""
    for bad in (0, -1, 2.5, True):
        with pytest.raises(InputError, match=name):
            CGSettings(**{name: bad})
    assert getattr(CGSettings(**{name: None}), name) is None
    assert getattr(CGSettings(), name) == default == documented


def test_the_space_is_made_once_per_fresh_solve(comm, caplog):
    """With the rotation free and found by the Newton on θ (``rotation_from=None``; the default
    finds it with the forces, whose steps take no space), the Newton's evaluations share the
    space of their solve: the fine level makes it once. A warm start (the next load of a sweep,
    from the last solution) makes none: it has little left to settle."""
    s = 1.0 / 128
    surface = fourier_surface(128, s, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                              short_cutoff_wavelength=8 * s, periodic=False, seed=1)
    problem = NormalProblem(surface, FLAT, comm, operator="fft")
    load = 0.01 * problem.topography.nominal_area

    def made(records):
        return [r.cg_step["nodes"] for r in records if hasattr(r, "cg_step") and "coarse space" in r.cg_step["restart"]]

    try:
        with make_solver(problem, "cg", settings=CGSettings(balancing_from=1, rotation_from=None)) as solver:
            with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
                free = solver.solve_load(load)
                fresh = made(caplog.records)
                caplog.clear()
                warm = solver.solve_load(1.05 * load)
                again = made(caplog.records)
                warm_charged = any(hasattr(r, "cg_step") and "charge on" in r.cg_step["restart"]
                                   for r in caplog.records)
        nodes = problem.size
    finally:
        problem.destroy()
    assert free.outer_iterations > 1                    # the Newton took several evaluations
    assert fresh.count(nodes) == 1
    assert again == [] and warm_charged                 # the warm solve took the hole charge, no space
    assert warm.residual <= CGSettings().tol


def test_a_coarse_matrix_without_a_cholesky_factor_falls_back_to_m_and_says_so(caplog):
    """With W negated E = Zᵀ W is negative definite: P g is M g exactly, and a warning says the
    preconditioner goes on without the space (once, however many sets follow)."""
    n = 32
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind="fft")
    try:
        nodes = np.flatnonzero(np.random.default_rng(2).random(n * n) < 0.1)
        space = BalancingSpace(flex.preconditioner, flex.layout, MPI.COMM_SELF, parts=2)
        space.make(nodes, single=False)
        space.W = -space.W

        def precondition(values):
            return flex.precondition_nodes(values, nodes)

        g = np.random.default_rng(3).standard_normal(nodes.size)
        with caplog.at_level(logging.WARNING, logger="roughcontact.operators.balancing"):
            z = space.apply(g, nodes, precondition)
            space.apply(g[1:], nodes[1:], lambda v: flex.precondition_nodes(v, nodes[1:]))
        np.testing.assert_array_equal(z, precondition(g))
        assert [r.levelname for r in caplog.records if "not positive definite" in r.getMessage()] == ["WARNING"]
    finally:
        flex.destroy()
