"""The Fourier preconditioner's edge correction against C⁻¹ built independently with numpy.

A = C⁻¹ is the inverse of the circulant of the Eq. 10 kernel folded onto C's
period, the grid with PERIOD_MARGIN nodes or more of zeros beyond it
(``embedding_period``); here it is made densely by numpy's 2-D FFT of
``wrapped_kernel`` on that period, not by the slab transforms of the
package. The weights are e_i = EDGE_SHARE · min(κ_i, EDGE_CAP · A_ii),
κ_i = Σ_{j∉S} (−A_ij) over the whole period (the margin is outside S),
summed here node by node: equal to round-off in double (1e-12 of A_ii); from
a single-precision product to 1e-6 of A_ii (its error is ~1e-7 of the
product's scale, A_ii here).
"""
from __future__ import annotations

import numpy as np
import pytest

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import CGSettings
from roughcontact.operators.flexibility import Flexibility
from roughcontact.operators.kernel import punch_kernel
from roughcontact.operators.preconditioner import EDGE_CAP, EDGE_SHARE, embedding_period
from roughcontact.surfaces import Topography, disc

ROCK = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
SPACING = 1e-4
N = 24


def wrapped_kernel(period: tuple[int, int], spacing: float, compliance: float) -> np.ndarray:
    """The Eq. 10 table on a grid of the period's size, folded onto it: k[min(i, L − i), min(j, L − j)]."""
    table = punch_kernel(period, spacing, compliance)
    i, j = np.arange(period[0]), np.arange(period[1])
    return table[np.ix_(np.minimum(i, period[0] - i), np.minimum(j, period[1] - j))]


def inverse_column(flexibility) -> np.ndarray:
    """A's column at node (0, 0) over C's whole period (the grid's own for the periodic operator),
    from numpy's FFT."""
    period = flexibility.shape if flexibility.periodic else embedding_period(flexibility.shape)
    symbol = np.fft.fft2(wrapped_kernel(period, flexibility.spacing, flexibility.compliance)).real
    return np.fft.ifft2(1.0 / symbol).real


def dense_inverse(flexibility) -> tuple[np.ndarray, float]:
    """(C⁻¹ between the n × n grid's nodes, by flat grid position; its row sum a₀ over the period)."""
    column = inverse_column(flexibility)
    (lx, ly), ny = column.shape, flexibility.shape[1]
    i, j = np.divmod(np.arange(flexibility.shape[0] * ny), ny)
    return column[(i[:, None] - i[None, :]) % lx, (j[:, None] - j[None, :]) % ly], float(column.sum())


def kappa_of(inverse: np.ndarray, row_sum: float, whole: np.ndarray) -> np.ndarray:
    """κ_i = Σ_{j∉S} (−A_ij) over the period = Σ_{j∈S} A_ij − a₀, at every node of the grid."""
    return inverse[:, whole].sum(axis=1) - row_sum


def grid_positions(flexibility) -> np.ndarray:
    """The flat grid position of each node this rank owns."""
    return flexibility.layout.rows[0] * flexibility.shape[1] + flexibility.layout.positions


@pytest.fixture(params=["square", "disc", "periodic"])
def flexibility(request, comm):
    """A bounded grid (C's period longer than it), a footprint inside it, or the periodic operator's
    grid (C's period the grid's own: the windows wrap onto the grid)."""
    mask = disc((N, N), SPACING, 0.45 * N * SPACING) if request.param == "disc" else None
    flex = Flexibility(Topography(np.zeros((N, N)), SPACING, mask), ROCK, comm,
                       kind="fft-periodic" if request.param == "periodic" else "fft")
    yield flex
    flex.destroy()


def members_of(flexibility, density: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random set S over the footprint, the same on every rank count: (mask over the whole
    grid, mask over this rank's nodes)."""
    shape = flexibility.shape
    whole = np.random.default_rng(seed).random(shape[0] * shape[1]) < density
    footprint = np.zeros(whole.size, dtype=bool)
    footprint[np.concatenate(flexibility.comm.allgather(grid_positions(flexibility)))] = True
    whole &= footprint
    return whole, whole[grid_positions(flexibility)]


@pytest.mark.parametrize("density", [0.05, 0.4, 0.9])
@pytest.mark.parametrize("single", [False, True])
def test_edge_weights_are_the_sums_of_the_inverse_circulant_off_the_set(comm, flexibility, density, single):
    """e_i = share · min(Σ_{j∉S} (−A_ij), cap · A_ii) on S, and the preconditioner's A_ii and row
    sum a₀ are the dense C⁻¹'s."""
    inverse, row_sum = dense_inverse(flexibility)
    pc = flexibility.preconditioner
    assert abs(pc.inverse_diagonal - inverse[0, 0]) <= 1e-12 * inverse[0, 0]
    assert abs(pc.inverse_row_sum - row_sum) <= 1e-10 * inverse[0, 0]
    whole, mine = members_of(flexibility, density, seed=5)
    kappa = kappa_of(inverse, row_sum, whole)
    expected = EDGE_SHARE * np.minimum(np.maximum(kappa, 0.0), EDGE_CAP * inverse[0, 0])
    nodes = np.flatnonzero(mine)
    weights = pc.edge_weights(nodes, single)
    assert weights.shape == nodes.shape
    np.testing.assert_allclose(weights, expected[grid_positions(flexibility)[nodes]], rtol=0,
                               atol=(1e-6 if single else 1e-12) * inverse[0, 0])
    assert comm.allreduce(int(np.count_nonzero(weights > 0.0))) > 0


@pytest.mark.parametrize("density", [0.02, 0.3, 0.7, 0.97])
def test_the_preconditioner_splits_into_differences_and_a_diagonal_off_the_set(comm, flexibility, density):
    """gᵀ R_S A R_Sᵀ g = ½ Σ_{i,j∈S} (−A_ij)(g_i − g_j)² + Σ_{i∈S} (a₀ + κ_i) g_i² (the split the
    correction rests on), with the package's product on S and the dense A for the sums; and
    the corrected preconditioner R_S A R_Sᵀ − diag(e_S) is positive definite on S (a few far
    entries of A are positive, so the split's difference part is not positive semi-definite
    by construction: this checks it on sets from sparse to nearly full)."""
    inverse, row_sum = dense_inverse(flexibility)
    pc = flexibility.preconditioner
    whole, mine = members_of(flexibility, density, seed=11)
    g_whole = np.random.default_rng(2).standard_normal(whole.size)
    nodes = np.flatnonzero(mine)
    z = flexibility.precondition_nodes(g_whole[grid_positions(flexibility)][nodes], nodes)
    form = comm.allreduce(float(g_whole[grid_positions(flexibility)][nodes] @ z))
    inside = np.flatnonzero(whole)
    block = inverse[np.ix_(inside, inside)]
    g = g_whole[inside]
    kappa = kappa_of(inverse, row_sum, whole)[inside]
    differences = 0.5 * np.sum(-block * (g[:, None] - g[None, :]) ** 2)
    assert abs(form - (differences + np.sum((pc.inverse_row_sum + kappa) * g ** 2))) <= 1e-10 * abs(form)
    weights = np.zeros(whole.size)
    weights[np.concatenate(comm.allgather(grid_positions(flexibility)[nodes]))] = np.concatenate(
        comm.allgather(pc.edge_weights(nodes)))
    corrected = block - np.diag(weights[inside])
    assert np.linalg.eigvalsh(corrected)[0] > 0.0


def test_edge_share_is_checked():
    with pytest.raises(InputError, match="edge_share"):
        CGSettings(edge_share=1.0)
    with pytest.raises(InputError, match="edge_share"):
        CGSettings(edge_share=-0.1)


def test_the_correction_lowers_the_condition_of_the_preconditioned_contact_block():
    """On the solved contact set of a rough surface (128², 335 nodes; each rank alone, the
    property is the operator's), the eigenvalues of M H_SS with M the plain R_S C⁻¹ R_Sᵀ span
    1.00-3.63 and with the corrected one 0.45-0.97: the correction takes the largest ones, on
    the islands' boundary, down more than the smallest. Required: the condition number falls
    by a fifth at least (measured: to 0.59 of it)."""
    from mpi4py import MPI

    from roughcontact.normal import NormalProblem, make_solver
    from roughcontact.surfaces import fourier_surface

    n = 128
    topo = fourier_surface(n, 1.0 / n, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8.0 / n, periodic=False, seed=1)
    problem = NormalProblem(topo, Interface(Material(1.0, 0.0)), MPI.COMM_SELF, operator="fft")
    with make_solver(problem, "cg") as solver:
        nodes = np.flatnonzero(solver.solve_load(0.01, rotation=(0.0, 0.0)).contact.reshape(-1))
    flex = problem.flexibility
    block, plain = np.empty((nodes.size, nodes.size)), np.empty((nodes.size, nodes.size))
    for k, node in enumerate(nodes):
        unit = np.zeros(problem.size)
        unit[node] = 1.0
        block[:, k] = flex.product(unit)[nodes]
        plain[:, k] = flex.precondition_nodes(unit[nodes], nodes)
    corrected = plain - np.diag(flex.preconditioner.edge_weights(nodes))
    conditions = []
    for m in (plain, corrected):
        values = np.sort(np.linalg.eigvals(m @ block).real)
        assert values[0] > 0.0
        conditions.append(values[-1] / values[0])
    assert conditions[1] <= 0.8 * conditions[0]
    problem.destroy()


@pytest.mark.parametrize("n", [24, 40])
def test_a_flat_punch_over_the_whole_grid_is_preconditioned_independently_of_n(n):
    """The whole grid in contact (a flat square punch, whose pressure is singular along the grid's
    edges): C on a period longer than the grid sees those edges, and M H_SS with the corrected M
    has eigenvalues 0.58-1.0 at 24² and 0.58-1.1 at 48² (condition 1.73 / 1.88; the plain M: 2.9 /
    3.4, smallest 0.99 / 0.97, the Schur complement bound of C = H). With the grid as C's own
    period the wrap joins opposite edges, the set fills the period (κ = 0: no correction) and
    the condition grows with n: 8.5 at 24², 10.4 at 32², 13.8 at 48². Required: a condition of
    at most 2.5 at 24² and 40², and a smallest eigenvalue of the plain M H of at least 0.9. Each
    rank alone (the property is the operator's)."""
    from mpi4py import MPI

    flex = Flexibility(Topography(np.zeros((n, n)), 1.0 / n), Interface(Material(1.0, 0.0)), MPI.COMM_SELF,
                       kind="fft")
    nodes = np.arange(n * n)
    block, plain = np.empty((n * n, n * n)), np.empty((n * n, n * n))
    for k in nodes:
        unit = np.zeros(n * n)
        unit[k] = 1.0
        block[:, k] = flex.product(unit)
        plain[:, k] = flex.precondition_nodes(unit, nodes)
    corrected = plain - np.diag(flex.preconditioner.edge_weights(nodes))

    def spectrum(m):                   # M H's eigenvalues, those of Lᵀ H L for M = L Lᵀ (M is SPD)
        lower = np.linalg.cholesky(0.5 * (m + m.T))
        return np.linalg.eigvalsh(lower.T @ block @ lower)

    values = spectrum(corrected)
    assert values[0] > 0.0 and values[-1] / values[0] <= 2.5
    assert spectrum(plain)[0] >= 0.9
    flex.destroy()


def test_the_active_sets_krylov_solves_take_the_share_from_the_options_database(comm):
    """``fourier_edge_share`` under the solver's prefix sets the PETSc PC's share: 0 gives the plain
    preconditioner (no weights), the default the corrected one, and a share outside [0, 1) is
    named in one line. At 0.3 E* the contact set (about half the 64² grid) is past the explicit
    blocks' size, so the Krylov solves run matrix-free with the Fourier PC. The active set's
    answer is the same either way (its Krylov solves are exact to rtol 1e-11; the forces to
    1e-9 of the largest)."""
    from roughcontact.normal import NormalProblem, make_solver
    from roughcontact.surfaces import fourier_surface

    n = 64
    topo = fourier_surface(n, 1.0 / n, hurst=0.8, rms_slope=1.0, rolloff_wavelength=1.0,
                           short_cutoff_wavelength=8.0 / n, periodic=False, seed=3)
    problem = NormalProblem(topo, Interface(Material(1.0, 0.0)), comm, operator="fft")
    results = {}
    for share in (None, 0.0):
        options = {} if share is None else {"options": {"fourier_edge_share": share}}
        with make_solver(problem, "ksp", **options) as solver:
            results[share] = solver.solve_load(0.3, rotation=(0.0, 0.0))
            pc = solver.inner.fourier
            assert pc.edge_share == (EDGE_SHARE if share is None else 0.0)
            assert (pc.edge is None) == (share == 0.0)
    scale = results[None].force.max()
    np.testing.assert_allclose(results[0.0].force, results[None].force, rtol=0, atol=1e-9 * scale)
    with pytest.raises(InputError, match="fourier_edge_share"):
        make_solver(problem, "ksp", options={"fourier_edge_share": 1.5})
    problem.destroy()


@pytest.mark.parametrize("density", [0.05, 0.4])
@pytest.mark.parametrize("single", [False, True])
def test_tracked_edge_weights_follow_small_changes_within_the_windows_tail(comm, flexibility, single, density,
                                                                          monkeypatch):
    """EdgeWeights keeps A 1_S and follows each change of S through windows of A (radius 4 here,
    so that what they leave out is visible), wrapped round the period like C: after every step
    its weights equal the dense ones to within share × (changed nodes since the last product) ×
    ``tail``, the largest |A_ij| outside the window (+ 1e-6 A_ii: A 1_S is kept in float32), with
    changes at the grid's edges and on both sides of the ranks' split; a change larger than one
    node in EDGE_UPDATES, or EDGE_REFRESH updates, takes the product again. On a sparse set (5 %)
    the product writes 1 at the set's positions; on a dense one (40 %, over one node in
    DENSE_WRITE) it takes the set's mask whole."""
    import roughcontact.operators.preconditioner as preconditioner

    monkeypatch.setattr(preconditioner, "EDGE_RADIUS", 4)
    monkeypatch.setattr(preconditioner, "EDGE_UPDATES", 20)                 # up to 28 of 576 nodes
    monkeypatch.setattr(preconditioner, "EDGE_REFRESH", 3)
    monkeypatch.setattr(preconditioner, "WINDOW_CHUNK", 3)                 # the windows in chunks
    flexibility._preconditioner = None                                      # made with radius 4
    pc = flexibility.preconditioner
    inverse, row_sum = dense_inverse(flexibility)
    column = inverse_column(flexibility)
    assert pc.window.shape == (9, 9)
    np.testing.assert_allclose(pc.window, column[np.ix_(np.arange(-4, 5) % column.shape[0],
                                                        np.arange(-4, 5) % column.shape[1])], rtol=1e-6)
    tracker = preconditioner.EdgeWeights(pc)
    whole, _ = members_of(flexibility, density, seed=8)
    rng = np.random.default_rng(9)
    corners = [0, N - 1, N * (N // 2) - 1, N * (N // 2), N * N - 1, N - 1 + N * (N - 1) // 2]
    since, taken = 0, []
    mine = np.zeros(flexibility.layout.local_size, dtype=bool)    # changed in place, as the CG's mask
    for step in range(9):
        if step == 6:
            flips = rng.choice(N * N, 60, replace=False)                     # too many: a product
        else:
            flips = np.concatenate([rng.choice(N * N, 4, replace=False), corners[step % 3::3]])
        if step:
            whole = whole.copy()
            whole[flips] = ~whole[flips]
        footprint = np.zeros(N * N, dtype=bool)
        footprint[np.concatenate(comm.allgather(grid_positions(flexibility)))] = True
        whole &= footprint
        mine[:] = whole[grid_positions(flexibility)]
        nodes = np.flatnonzero(mine)
        before = tracker.products
        weights = tracker.weights(nodes, mine, single)
        kappa = kappa_of(inverse, row_sum, whole)
        expected = EDGE_SHARE * np.minimum(np.maximum(kappa, 0.0), EDGE_CAP * inverse[0, 0])
        since = 0 if tracker.products > before else since + int(np.unique(flips).size if step else 0)
        if tracker.products > before:
            taken.append(step)
        bound = EDGE_SHARE * since * pc.tail + 1e-6 * inverse[0, 0]          # A 1_S kept in float32
        np.testing.assert_allclose(weights, expected[grid_positions(flexibility)[nodes]], rtol=0, atol=bound)
    assert taken == [0, 4, 6]          # the first; after EDGE_REFRESH updates; 60 changes > 576 / 20
    assert 0.0 < pc.tail < 0.05 * inverse[0, 0]
