"""A normal problem keeps only its rank's share of the N nodes; what it derives from all of them
(centroid, extent, height range, the hull of the footprint, gathered fields) is what numpy
computes from the whole grid, on any number of ranks."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from roughcontact.materials import Interface, Material
from roughcontact.normal import NormalProblem
from roughcontact.normal import problem as problem_module
from roughcontact.operators.set_blocks import capacity
from roughcontact.surfaces import Topography

from conftest import traced_peak, traced_share

ROCK = Interface(Material(30e9, 0.25))


def disc_topography(n: int = 48, seed: int = 3, shape: str = "disc") -> Topography:
    """Random heights on a disc-shaped footprint (rows of unequal length), or on the first 20 rows
    of the grid (``"band"``: on two ranks or more, the second rank owns no node)."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    if shape == "band":
        footprint = (i < 20) & (j > 5)
    else:
        footprint = (i - 0.45 * n) ** 2 + (j - 0.55 * n) ** 2 <= (0.4 * n) ** 2
    heights = np.where(footprint, rng.standard_normal((n, n)) * 1e-6, np.nan)
    return Topography(heights, 1e-4, footprint=footprint)


@pytest.mark.parametrize("shape", ["disc", "band"])
def test_derived_geometry_equals_the_whole_grid_computation(comm, shape):
    """Centroid, extent, height range and first-touch gap against numpy on all nodes (exact up to
    round-off of sums: rtol 1e-14), also where a rank owns no node."""
    topo = disc_topography(shape=shape)
    problem = NormalProblem(topo, ROCK, comm, operator="fft")
    s = topo.spacing
    nodes = np.argwhere(topo.footprint)
    centroid = nodes.mean(axis=0) * s
    np.testing.assert_allclose(problem.centroid, centroid, rtol=1e-14)
    xy = nodes * s - centroid
    assert problem.extent == pytest.approx(np.abs(xy).max(), rel=1e-14)
    heights = topo.heights[topo.footprint]
    assert problem.height_range == pytest.approx(np.ptp(heights), rel=1e-14)
    gap0 = problem.gather(problem.gap0)
    np.testing.assert_allclose(gap0, heights.max() - heights, rtol=0, atol=1e-20)
    np.testing.assert_allclose(problem.gather(problem.x), xy[:, 0], rtol=0, atol=1e-14 * s)
    np.testing.assert_allclose(problem.gather(problem.y), xy[:, 1], rtol=0, atol=1e-14 * s)
    problem.destroy()


@pytest.mark.parametrize("shape", ["disc", "band", "square"])
def test_moments_and_the_tilted_interpenetration_by_rows_and_columns(comm, shape, monkeypatch):
    """The problem keeps the coordinates by grid row and column, not by node. The load's moments
    (Σ p, Σ p y, Σ p x; Eq. 8) summed by rows and columns equal numpy's sums over all nodes to
    round-off (rtol 1e-13: sums of ~2000 terms of one sign in double, a different order), and the
    interpenetration w = δz − θx y − θy x − gap0 (Eq. 7) taken by rows and columns is the
    per-node formula bit for bit (the same operations on the same values), as is C = [1, −y, −x]
    at chosen nodes, on whole rows
    (``square``), partial rows (``disc``) and a rank without nodes (``band``, two ranks)."""
    topo = disc_topography(shape="disc" if shape == "square" else shape)
    if shape == "square":
        topo = Topography(np.nan_to_num(topo.heights), topo.spacing)
    problem = NormalProblem(topo, ROCK, comm, operator="fft")
    nodes = np.argwhere(topo.footprint)
    xy = nodes * topo.spacing - problem.centroid
    forces = np.random.default_rng(11).random(nodes.shape[0])
    mine = forces[problem.start:problem.stop]
    expected = [forces.sum(), forces @ xy[:, 1], forces @ xy[:, 0]]
    np.testing.assert_allclose(problem.allsum(problem.moments(mine)), expected, rtol=1e-13)
    rigid = np.array([2e-6, 3e-4, -5e-4])
    x, y = xy[problem.start:problem.stop, 0], xy[problem.start:problem.stop, 1]
    per_node = rigid[0] - rigid[1] * y - rigid[2] * x - problem.gap0
    assert np.array_equal(problem.interpenetration(rigid), per_node)
    assert np.array_equal(problem.interpenetration(np.array([2e-6, 0.0, 0.0])), 2e-6 - problem.gap0)
    # C = [1, −y, −x] (Eq. 8) at some of the rank's nodes, by index and by mask: the coordinates' bits,
    # in one chunk and in chunks of 7 nodes (the last one short)
    chosen = np.random.default_rng(12).random(x.size) < 0.3
    columns = np.stack([np.ones(x.size), -y, -x], axis=1)[chosen]
    for chunk in (problem_module.ARMS_CHUNK, 7):
        monkeypatch.setattr(problem_module, "ARMS_CHUNK", chunk)
        assert np.array_equal(problem.columns_at(chosen), columns)
        assert np.array_equal(problem.columns_at(np.flatnonzero(chosen)), columns)
        assert np.array_equal(problem.arms_at(chosen), columns[:, 1:].T)
        assert problem.arms_at(chosen).flags.c_contiguous
    problem.destroy()


@pytest.mark.parametrize("shape", ["disc", "square"])
def test_the_columns_of_a_set_allocate_their_own_size_and_one_chunks_temporaries(shape, monkeypatch):
    """C's columns at a set S (the free rotation's C_S, Eq. 8) allocate the result and one chunk's
    temporaries: traced peak ≤ 24 |S| (columns_at) or 16 capacity(|S|) (arms_at, a set-sized block:
    :mod:`roughcontact.operators.set_blocks`) + 32 B per chunk node (its
    positions, rows and columns, and one coordinate taken) + 8 KiB of numpy's bookkeeping (the
    arrays' headers). Made whole, the positions, rows, columns and three stacked columns had taken
    about 72 B per node of the set beside the result, the peak of a study's load sweep near full
    contact. One rank, a 160² grid (about 11 000 nodes of the set) in chunks of 256 nodes."""
    from mpi4py import MPI

    monkeypatch.setattr(problem_module, "ARMS_CHUNK", 256)
    topo = disc_topography(n=160, shape="disc" if shape == "square" else shape)
    if shape == "square":
        topo = Topography(np.nan_to_num(topo.heights), topo.spacing)
    problem = NormalProblem(topo, ROCK, MPI.COMM_SELF, operator="fft")
    nodes = np.flatnonzero(np.random.default_rng(5).random(problem.local_size) < 0.9)
    problem.arms_at(nodes[:10])                 # first calls of numpy's paths, not counted
    allowance = 32 * 256 + 8192
    assert traced_peak(problem.columns_at, nodes) <= 24 * nodes.size + allowance
    # arms_at's rows are a set-sized block: their storage is the ladder's size (≤ 2^(1/4) |S|)
    assert traced_peak(problem.arms_at, nodes) <= 16 * capacity(nodes.size) + allowance
    problem.destroy()


@pytest.mark.parametrize("shape", ["disc", "band"])
def test_load_point_inside_is_the_hull_of_all_nodes(comm, shape):
    """The hull built from each grid row's end nodes is the hull of every node: points on a ring
    around the centroid are inside exactly when scipy's hull of all nodes says so."""
    topo = disc_topography(shape=shape)
    problem = NormalProblem(topo, ROCK, comm, operator="fft")
    xy = np.argwhere(topo.footprint) * topo.spacing - problem.centroid
    hull = ConvexHull(xy)
    for radius in np.linspace(0.5, 1.2, 8) * problem.extent:
        for angle in np.linspace(0.0, 2.0 * np.pi, 13)[:-1]:
            point = radius * np.array([np.cos(angle), np.sin(angle)])
            distance = np.max(hull.equations[:, :2] @ point + hull.equations[:, 2])
            if abs(distance) < 1e-3 * topo.spacing:
                continue                      # on the boundary: either answer is right
            assert problem.load_point_inside(point) == (distance < 0.0)
    problem.destroy()


def test_gather_puts_each_ranks_values_in_node_order(comm):
    """Floats and booleans gathered in place equal the whole-grid vectors; a vector of the wrong
    length is refused with its shape."""
    topo = disc_topography()
    problem = NormalProblem(topo, ROCK, comm, operator="fft")
    nodes = np.argwhere(topo.footprint)
    order = nodes[:, 0] * 1000 + nodes[:, 1]
    local = problem.nodes[:, 0] * 1000 + problem.nodes[:, 1]
    np.testing.assert_array_equal(problem.gather(local.astype(float)), order)
    np.testing.assert_array_equal(problem.gather(local % 3 == 0), order % 3 == 0)
    with pytest.raises(ValueError, match="gather takes"):
        problem.gather(np.zeros(problem.local_size + 1))
    problem.destroy()


@pytest.mark.parametrize("scene", ["full", "scene"])
def test_a_solve_allocates_within_the_memory_estimates_share_of_one_rank(scene):
    """The guard of a study reserves ``operator_memory`` for each solve: N (REPLICATED +
    DISTRIBUTED / ranks) bytes (roughcontact.operators.memory), REPLICATED for the gathered fields
    and what the C allocator keeps of freed blocks. A solve that keeps its fields by rows may then
    allocate at most DISTRIBUTED B per node on one rank. Traced allocations (tracemalloc:
    deterministic, unlike the resident set) of set-up and a nested solve at 256², one rank:
    near full contact (fractal dimension 2.5 at 1 E*, 86 % of the nodes in the free set, the
    scene that takes the most) 209 B/node, the large-grid scene (2 %) 185. When each iteration's
    vectors of the set's size were still held through the next products, the same solves took
    332 and 268: near full contact above it (DISTRIBUTED, 290 since it bounds load sweeps; 265
    then). Run on each rank alone."""
    from mpi4py import MPI

    from benchmarks.bench_products import PRESSURES, SHAPES
    from benchmarks.common import scene_problem, scene_topography, solve_scene
    from roughcontact.operators.memory import DISTRIBUTED

    n = 256
    topography = scene_topography(n, **SHAPES[scene])

    def solve() -> None:
        with scene_problem(topography, MPI.COMM_SELF) as problem:
            solve_scene(problem, PRESSURES[scene], gather=False)

    solve()                                    # FFT plans and first-use buffers, not counted
    peak = traced_peak(solve)
    assert peak / n ** 2 <= DISTRIBUTED, (scene, peak / n ** 2)


def test_a_study_tasks_load_sweep_allocates_within_the_memory_estimates_share_of_one_rank():
    """A study's task is a sweep of warm-started loads, and the estimate reserves for it too: what
    a rank allocates is at most DISTRIBUTED B per node, the rest of its resident peak being the
    allocator's (REPLICATED). Traced set-up and the ensemble task's 12 loads (midpoint, Δ 2.3, to
    67 % in contact at 257²; the rotation free, a study's default, and the fields by rows), one
    rank: 246 B/node. While each set's coordinates C_S were made whole (the positions, rows,
    columns and three stacked columns), the same sweep took 273, and 287 at 513², against 251
    since."""
    from mpi4py import MPI

    from benchmarks.common import ensemble_task
    from roughcontact.normal import make_solver
    from roughcontact.operators.memory import DISTRIBUTED

    topography, rock, loads = ensemble_task(8)

    def sweep() -> None:
        with NormalProblem(topography, rock, MPI.COMM_SELF, operator="fft") as problem, \
                make_solver(problem, "cg") as solver:
            for load in loads:
                solver.solve_load(load, gather=False)

    sweep()                                    # FFT plans and first-use buffers, not counted
    peak = traced_peak(sweep)
    assert peak / topography.heights.size <= DISTRIBUTED, peak / topography.heights.size


@pytest.mark.parametrize("rotation_from", [None, "default"])
def test_a_free_rotation_solve_within_the_memory_estimate_with_its_explicit_blocks(rotation_from):
    """With the rotation free the CG's Newton (``rotation_from=None``) takes Hessians on the
    contact set, through explicit blocks H_SS where the set is small, and keeps the last one
    through the next evaluations: on the large-grid scene at 256² (a load point off the centroid)
    about 1 300 contact nodes, a 13 MB block. Traced set-up and solve: 501 B/node, above
    DISTRIBUTED (290), within operator_memory, which adds the blocks' bound (explicit_block_memory:
    the block, the Eq. 10 table it reads, a chunk's temporaries). Before the blocks' bound was
    counted, and while they kept the table mirrored to signed offsets and index temporaries as
    large as the block, the same solve took 665 B/node against an estimate of 315. By default the
    primal–dual steps find the rotation with the forces at 256² (no Hessian, no block), within
    the same estimate. One rank."""
    from mpi4py import MPI

    from benchmarks.common import scene_problem, scene_topography
    from roughcontact.normal import CGSettings, make_solver
    from roughcontact.operators import operator_memory

    n = 256
    topography = scene_topography(n)
    load = 0.01 * topography.nominal_area
    settings = CGSettings() if rotation_from == "default" else CGSettings(rotation_from=rotation_from)
    built = []

    def solve() -> None:
        with scene_problem(topography, MPI.COMM_SELF) as problem:
            with make_solver(problem, "cg", settings=settings) as solver:
                moments = (0.02 * load * problem.extent, -0.01 * load * problem.extent)
                solver.solve_load(load, moments=moments, gather=False)
            built.append(problem.flexibility._table is not None)     # an explicit block was read from it

    solve()                                    # FFT plans and first-use buffers, not counted
    peak = traced_peak(solve)
    assert built == ([True, True] if rotation_from is None else [False, False])
    assert peak <= operator_memory("fft", n * n, 1), (peak / n ** 2, operator_memory("fft", n * n, 1) / n ** 2)


def test_set_up_memory_divides_over_the_ranks(comm):
    """The operator's set-up (its rows of the Eq. 10 table, symbols, nodes, coordinates) on k ranks
    allocates at most 1/k + 0.1 of what one rank allocates for the whole grid (the ideal is 1/k;
    0.1 for per-rank buffers rounded to whole rows and columns and a few small replicated arrays).
    Measured at 256²: 0.57 on two ranks, 0.29 on four; when every rank held the whole table, node
    list and coordinates, 0.68 and 0.53."""
    if comm.Get_size() == 1:
        pytest.skip("needs more than one rank")
    n = 256
    topo = Topography(np.random.default_rng(1).standard_normal((n, n)) * 1e-6, 1e-4)

    def set_up(on) -> None:
        with NormalProblem(topo, ROCK, on, operator="fft") as problem:
            problem.flexibility.preconditioner

    share, ranks = traced_share(comm, set_up), comm.Get_size()
    assert share <= 1.0 / ranks + 0.1, (share, ranks)
