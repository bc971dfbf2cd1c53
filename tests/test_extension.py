"""The Fourier preconditioner on a smooth extension of the set's field (roughcontact/operators/extension.py).

M_T = Eᵀ A E, E = [I; T], A = C⁻¹ on the grid, T the normalised box average. Checked
against its definition built here as dense matrices from an independent box sum; against
the bound that makes it safe for any T (the Schur complement of A on the set is the least
of Eᵀ A E over extensions, so M_T − Σ is positive semi-definite); against M itself where T
vanishes; for the boundary share of sets whose share is known; for the same product on any
rank count; and in whole solves, where it changes the path, not the state.
"""
from __future__ import annotations

import logging

import numpy as np
import pytest
from mpi4py import MPI
from numpy.lib.stride_tricks import sliding_window_view

from roughcontact.materials import Interface, Material
from roughcontact.normal import CGSettings, NormalProblem, constrained_cg, make_solver
from roughcontact.operators import extension as extension_module
from roughcontact.operators.extension import (
    EXTENSION_BOUNDARY,
    EXTENSION_FLOOR,
    EXTENSION_WIDTH,
    SmoothExtension,
)
from roughcontact.operators.flexibility import Flexibility
from roughcontact.surfaces import Topography, midpoint_surface

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
SPACING = 1e-4


def flexibility(n, comm):
    return Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, comm, kind="fft")


def box_sum(field: np.ndarray, width: int) -> np.ndarray:
    """The mean over the width × width window about each node, zero beyond the grid: windows of
    the zero-padded field summed, not a running sum."""
    half = width // 2
    return sliding_window_view(np.pad(field, half), (width, width)).sum(axis=(2, 3)) / width**2


def dense_extension(flex, n: int, nodes: np.ndarray, width: int, floor: float,
                    footprint: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(Eᵀ A E, A on the grid) as dense matrices: A's columns by the preconditioner of the whole
    n² grid ``flex`` applied to unit fields on every node, T by the box mean of each unit field on
    S (``nodes``, grid indices), divided by max(box mean of 1_S, τ) on O (the weight rounded to
    float32, as the package keeps it) and zero off ``footprint`` (None: the whole grid)."""
    size = n * n
    every = np.arange(size)
    A = np.array([flex.precondition_nodes(e, every) for e in np.eye(size)]).T
    members = np.zeros((n, n))
    members.reshape(-1)[nodes] = 1.0
    weight = (1.0 / np.maximum(box_sum(members, width), floor)).astype(np.float32).astype(float)
    weight[members > 0] = 0.0
    if footprint is not None:
        weight[~footprint] = 0.0
    E = np.zeros((size, nodes.size))
    E[nodes, np.arange(nodes.size)] = 1.0
    for k, node in enumerate(nodes):
        unit = np.zeros((n, n))
        unit.reshape(-1)[node] = 1.0
        E[:, k] += (box_sum(unit, width) * weight).reshape(-1)
    return E.T @ A @ E, A


def dense_of(extension, nodes, single=False):
    return np.array([extension.apply(e, nodes, single) for e in np.eye(nodes.size)]).T


@pytest.mark.parametrize("kind, block_bytes, workers", [
    ("fft", extension_module.BLOCK_BYTES, 1),           # the box in one block of rows
    ("fft", 8 * 20 * 3, 1),                             # in blocks of 3 rows, which end inside the halo
    ("fft", 1, 1),                                      # in blocks of one row
    ("fft", 8 * 20 * 3, 2),                             # two threads, each its rows' blocks and passes
    ("fft-periodic", extension_module.BLOCK_BYTES, 1),  # the product's rows as wide as the grid's
])
def test_the_product_is_its_definition_and_symmetric(monkeypatch, kind, block_bytes, workers):
    """M_T on a random set of a quarter of a 20² grid, as a dense matrix from the package, against
    Eᵀ A E built from the definition (:func:`dense_extension`), in double precision: to 1e-7 of
    the largest entry, as the package makes its float32 weights from a float32 box sum of 1_S
    where the reference rounds a float64 one (each weight within a few float32 ulps, 3e-7 of
    itself, on the part of M_T that T carries; 1-5e-9 of the largest entry seen); symmetric to
    1e-12 of it, as Eᵀ A E is (T and Tᵀ take the same weights). The box filter made in blocks of
    a few rows, on two threads (the grid is too small for the transforms' own), and A the periodic
    operator's (whose product is read at S without a crop), give the same."""
    monkeypatch.setattr(extension_module, "BLOCK_BYTES", block_bytes)
    n = 20
    flex = Flexibility(Topography(np.zeros((n, n)), SPACING), ROCK, MPI.COMM_SELF, kind=kind)
    try:
        nodes = np.flatnonzero(np.random.default_rng(3).random(n * n) < 0.25)
        made = SmoothExtension(flex.preconditioner, flex.layout, MPI.COMM_SELF)
        made.workers = workers
        got = dense_of(made, nodes)
        expected, _ = dense_extension(flex, n, nodes, EXTENSION_WIDTH, EXTENSION_FLOOR)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7 * scale)
        assert np.abs(got - got.T).max() <= 1e-12 * scale
    finally:
        flex.destroy()


@pytest.mark.parametrize("density", [0.1, 0.5, 0.9])
def test_it_is_at_least_the_schur_complement_on_the_set(density):
    """The Schur complement Σ = A_SS − A_SO A_OO⁻¹ A_OS (O the grid's other nodes) is the least of
    Eᵀ A E over every extension E = [I; T], so M_T − Σ is positive semi-definite whatever T is
    (and so M_T C_SS ≥ 1): its smallest eigenvalue is above −1e-10 of the largest entry (the
    round-off of A_OO⁻¹ on a 20² grid), on sets from sparse to nearly full, where M_T differs
    from M."""
    n = 20
    flex = flexibility(n, MPI.COMM_SELF)
    try:
        members = np.random.default_rng(8).random(n * n) < density
        nodes, outside = np.flatnonzero(members), np.flatnonzero(~members)
        extension = SmoothExtension(flex.preconditioner, flex.layout, MPI.COMM_SELF)
        got = dense_of(extension, nodes)
        _, A = dense_extension(flex, n, nodes, EXTENSION_WIDTH, EXTENSION_FLOOR)
        schur = A[np.ix_(nodes, nodes)] - A[np.ix_(nodes, outside)] @ np.linalg.solve(
            A[np.ix_(outside, outside)], A[np.ix_(outside, nodes)])
        plain = A[np.ix_(nodes, nodes)]
        scale = np.abs(plain).max()
        assert np.linalg.eigvalsh(0.5 * (got + got.T) - schur)[0] >= -1e-10 * scale
        assert np.abs(got - plain).max() > 1e-3 * scale          # and it is not M
    finally:
        flex.destroy()


def test_what_one_application_keeps_does_not_reach_the_next(comm):
    """One object applied in turn to two sets, in double and single precision and back (its kept
    scratch: g's field, zero off the set it was last filled for; reallocated when the precision
    changes), and to a third set written into the second's index array in place, gives each time
    the same bits as a new object applied once, on any rank count."""
    n = 40
    rng = np.random.default_rng(21)
    flex = flexibility(n, comm)
    try:
        r0, r1 = flex.layout.rows
        sets = [np.flatnonzero(rng.random((r1 - r0) * n) < share) for share in (0.2, 0.6)]
        refilled = sets[1].copy()
        kept = SmoothExtension(flex.preconditioner, flex.layout, comm)
        for nodes, single in [(sets[0], False), (sets[0], False), (refilled, False), (refilled, True),
                              (sets[0], True), (sets[0], False), (refilled, False), ("in place", False)]:
            if isinstance(nodes, str):              # another set of the same size, in the same array
                refilled[:] = np.sort(rng.choice((r1 - r0) * n, refilled.size, replace=False))
                nodes = refilled
            g = rng.standard_normal(nodes.size)
            fresh = SmoothExtension(flex.preconditioner, flex.layout, comm).apply(g, nodes, single)
            np.testing.assert_array_equal(kept.apply(g, nodes, single), fresh)
    finally:
        flex.destroy()


def test_without_an_extension_it_is_the_plain_preconditioner():
    """With the floor τ so high that T g is 1e-30 of g, M_T g is R_S A R_Sᵀ g, the solver's
    preconditioner without its corrections, to 1e-12 of the largest value."""
    n = 32
    flex = flexibility(n, MPI.COMM_SELF)
    try:
        nodes = np.flatnonzero(np.random.default_rng(5).random(n * n) < 0.3)
        g = np.random.default_rng(6).standard_normal(nodes.size)
        extension = SmoothExtension(flex.preconditioner, flex.layout, MPI.COMM_SELF, floor=1e30)
        expected = flex.precondition_nodes(g, nodes)
        np.testing.assert_allclose(extension.apply(g, nodes), expected, rtol=0,
                                   atol=1e-12 * np.abs(expected).max())
    finally:
        flex.destroy()


@pytest.mark.parametrize("shape, expected", [
    ("island and dust", (20 + 10) / (36 + 10)),       # a 6 × 6 island: 20 rim nodes; 10 lone nodes
    ("large island", 44 / 144),                       # a 12 × 12 island: 44 rim nodes
    ("corner island", 20 / 36),                       # 6 × 6 in the corner: beyond the grid is outside
])
def test_the_boundary_share_is_counted_across_ranks(comm, shape, expected):
    """The share of the set's nodes with a 4-neighbour outside it, for sets whose share is known,
    the first two islands straddling the rows where two ranks meet (16 of 32): exact. Beyond the
    grid counts as outside (the punch ends there), so an island in the corner has the rim of one
    inside the grid."""
    n = 32
    grid = np.zeros((n, n), dtype=bool)
    if shape == "island and dust":
        grid[13:19, 5:11] = True
        grid[2, 2:22:2] = True
    elif shape == "large island":
        grid[10:22, 10:22] = True
    else:
        grid[0:6, 0:6] = True
    flex = flexibility(n, comm)
    try:
        r0, r1 = flex.layout.rows
        local = np.flatnonzero(grid[r0:r1])
        extension = SmoothExtension(flex.preconditioner, flex.layout, comm)
        share = extension.boundary_share(local)
        assert share == pytest.approx(expected, abs=1e-15)
        assert extension.chosen(local) == (expected >= EXTENSION_BOUNDARY)
    finally:
        flex.destroy()


@pytest.mark.parametrize("single", [False, True])
def test_the_product_is_the_same_on_any_rank_count(comm, single):
    """M_T g on this communicator's slabs (the box filters take their halo rows from the
    neighbouring rank) against the same on one rank over the whole grid, for a dust over a 48²
    grid: to 1e-12 of the largest value in double precision and 1e-5 in single (float32's
    transforms and sums)."""
    n = 48
    rng = np.random.default_rng(9)
    members = rng.random(n * n) < 0.2
    g = rng.standard_normal(n * n)
    spread, whole = flexibility(n, comm), flexibility(n, MPI.COMM_SELF)
    try:
        r0, r1 = spread.layout.rows
        local = np.flatnonzero(members[r0 * n:r1 * n])
        got = SmoothExtension(spread.preconditioner, spread.layout, comm).apply(
            g[r0 * n:r1 * n][local], local, single)
        every = np.flatnonzero(members)
        expected = SmoothExtension(whole.preconditioner, whole.layout, MPI.COMM_SELF).apply(g[every], every, single)
        at = np.searchsorted(every, r0 * n + local)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(got, expected[at], rtol=0, atol=(1e-5 if single else 1e-12) * scale)
    finally:
        spread.destroy()
        whole.destroy()


def test_a_footprint_that_is_not_the_whole_grid():
    """On a footprint with a hole (the nodes of a disc left out of a 20² grid: no unknowns there)
    M_T is Eᵀ A E over the footprint's nodes only: the reference's A and E on the whole grid,
    with the disc's nodes carrying neither the set nor the extension (their weight is zero), to
    1e-7 of the largest entry as in the first test."""
    n = 20
    i, j = np.indices((n, n))
    footprint = (i - 9.5) ** 2 + (j - 9.5) ** 2 > 16.0
    topography = Topography(np.zeros((n, n)), SPACING, footprint=footprint)
    flex = Flexibility(topography, ROCK, MPI.COMM_SELF, kind="fft")
    try:
        assert not flex.layout.whole_rows
        grid_nodes = np.flatnonzero(footprint)                 # each unknown's grid node
        chosen = np.flatnonzero(np.random.default_rng(12).random(grid_nodes.size) < 0.3)
        extension = SmoothExtension(flex.preconditioner, flex.layout, MPI.COMM_SELF)
        got = dense_of(extension, chosen)
        whole = flexibility(n, MPI.COMM_SELF)
        try:
            expected, _ = dense_extension(whole, n, grid_nodes[chosen], EXTENSION_WIDTH, EXTENSION_FLOOR,
                                          footprint)
        finally:
            whole.destroy()
        scale = np.abs(expected).max()
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7 * scale)
    finally:
        flex.destroy()


def test_the_halo_reaches_past_a_thin_neighbour(comm):
    """A grid of 5 rows (2 and 3 rows on two ranks) whose box reaches 3 rows each way: the halo
    spans more than a neighbour holds, and the grid's edge clips it. M_T g and the boundary share
    are the one-rank ones: to 1e-12 of the largest value (double precision), and exactly."""
    shape = (5, 40)
    rng = np.random.default_rng(13)
    members = rng.random(shape[0] * shape[1]) < 0.3
    g = rng.standard_normal(members.size)
    make = lambda c: Flexibility(Topography(np.zeros(shape), SPACING), ROCK, c, kind="fft")  # noqa: E731
    spread, whole = make(comm), make(MPI.COMM_SELF)
    try:
        r0, r1 = spread.layout.rows
        ny = shape[1]
        local = np.flatnonzero(members[r0 * ny:r1 * ny])
        mine = SmoothExtension(spread.preconditioner, spread.layout, comm)
        got = mine.apply(g[r0 * ny:r1 * ny][local], local)
        every = np.flatnonzero(members)
        one = SmoothExtension(whole.preconditioner, whole.layout, MPI.COMM_SELF)
        expected = one.apply(g[every], every)
        at = np.searchsorted(every, r0 * ny + local)
        np.testing.assert_allclose(got, expected[at], rtol=0, atol=1e-12 * np.abs(expected).max())
        assert mine.boundary_share(local) == one.boundary_share(every)
    finally:
        spread.destroy()
        whole.destroy()


def dust_problem(comm):
    """A smooth surface at low slopes (the ensemble task's: midpoint, Δ = 2.3, rms 10 µm over
    12.9 mm at 129²) loaded to 4e-4 E* A0: about a tenth of the nodes in contact, on hundreds
    of islands of a few nodes."""
    surface = midpoint_surface(7, 2.3, spacing=SPACING, rms_height=1e-5, seed=1)
    problem = NormalProblem(surface, ROCK, comm, operator="fft")
    return problem, 4e-4 * ROCK.contact_modulus * problem.topography.nominal_area


@pytest.mark.parametrize("path", ["constrained CG", "primal-dual steps"])
def test_a_solve_with_the_extension_reaches_the_same_state_on_any_rank_count(comm, caplog, monkeypatch, path):
    """On the dust the extension is taken (from the first grid up: ``extension_from`` 1) where the
    hole charge would be: the constrained CG's trace shows it switched on, and its directions go
    through it; the primal–dual steps (from any start) take it on their held sets, and settle the
    fine level's set themselves. Edge weights made for a set are not followed by M_T on that set
    (M_T replaces them). The state is the one without
    it to 1e-6 of the largest force (the CG's tolerance of 1e-8 times the condition of H on the
    set, test_normal_cg.py), on any rank count, and the two paths differ."""
    problem, load = dust_problem(comm)
    steps = {"primal_dual_from": 1, "primal_dual_share": 0.0} if path == "primal-dual steps" else \
        {"primal_dual_from": None}
    try:
        def solve(**settings):
            with make_solver(problem, "cg", settings=CGSettings(**steps, **settings)) as solver:
                return solver.solve_load(load, rotation=(0.0, 0.0))

        without = solve(extension_from=None)
        applied, settled, inside = [], [], [False]
        events = []                                     # (what, the set) in the order they came
        original, settle = SmoothExtension.apply, constrained_cg.settle
        made = constrained_cg.ConstrainedCGSolver._edge_weights
        plain = constrained_cg.ConstrainedCGSolver._precondition

        def counted(self, *args):
            applied.append(inside[0])                   # whether within the primal-dual steps
            events.append(("extension", hash(args[1].tobytes())))
            return original(self, *args)

        def weighted(self, edges, nodes, members, single, correcting, holes):
            if correcting:
                events.append(("weights", hash(nodes.tobytes())))
            return made(self, edges, nodes, members, single, correcting, holes)

        def preconditioned(self, g, nodes, single, edge):
            events.append(("corrected" if edge is not None else "plain", hash(nodes.tobytes())))
            return plain(self, g, nodes, single, edge)

        def watched(*args, **kwargs):
            inside[0] = True
            try:
                result = settle(*args, **kwargs)
            finally:
                inside[0] = False
            settled.append(result.converged)
            return result

        monkeypatch.setattr(SmoothExtension, "apply", counted)
        monkeypatch.setattr(constrained_cg, "settle", watched)
        monkeypatch.setattr(constrained_cg.ConstrainedCGSolver, "_edge_weights", weighted)
        monkeypatch.setattr(constrained_cg.ConstrainedCGSolver, "_precondition", preconditioned)
        with caplog.at_level(logging.DEBUG, logger="roughcontact.normal.constrained_cg"):
            extended = solve(extension_from=1)
    finally:
        problem.destroy()
    if path == "constrained CG":
        switched = [record.cg_step["restart"] for record in caplog.records
                    if hasattr(record, "cg_step") and "extension on" in record.cg_step["restart"]]
        assert switched and applied and not settled
    else:                                               # taken within the steps, which settled the set
        assert any(applied) and settled and settled[-1]
    assert 0.03 < without.contact_fraction < 0.3
    assert extended.linear_iterations != without.linear_iterations
    # M_T replaces the edge correction and the hole charge: weights made for a set are next used
    # by the corrected preconditioner, never by M_T on that set (the code before made them first)
    assert any(what == "extension" for what, _ in events)
    for k, (what, nodes) in enumerate(events):
        if what == "weights":
            following = next((event for event in events[k + 1:] if event[0] != "weights"), None)
            assert following != ("extension", nodes)
    scale = without.force.max()
    np.testing.assert_allclose(extended.force, without.force, rtol=0, atol=1e-6 * scale)
    assert extended.residual <= CGSettings().tol


def test_an_even_box_and_a_floor_of_zero_are_refused():
    """An even box has no centre node: its filter would not be symmetric, nor M_T. A floor of 0
    divides by B(1_S) = 0 far from the set."""
    flex = flexibility(16, MPI.COMM_SELF)
    try:
        with pytest.raises(ValueError, match="odd"):
            SmoothExtension(flex.preconditioner, flex.layout, MPI.COMM_SELF, width=6)
        with pytest.raises(ValueError, match="floor"):
            SmoothExtension(flex.preconditioner, flex.layout, MPI.COMM_SELF, floor=0.0)
    finally:
        flex.destroy()
