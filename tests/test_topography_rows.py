"""A topography held by rows (each rank its own grid rows) is the whole topography cut into the
ranks' rows: the same layout, the same coarse grids, the same solve bit for bit; what needs the
whole surface on every rank says so in one line."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import NormalProblem, make_solver
from roughcontact.surfaces import Topography, TopographyRows, coarsen
from roughcontact.surfaces.rows import split
from roughcontact.tangential import CattaneoSolver

from conftest import traced_share

ROCK = Interface(Material(30e9, 0.25))
FIELDS = ("force", "pressure", "contact", "gap")


def disc_topography(n: int, seed: int = 5) -> Topography:
    """Random heights on a disc-shaped footprint (rows of unequal length, NaN outside)."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    footprint = (i - 0.45 * n) ** 2 + (j - 0.55 * n) ** 2 <= (0.4 * n) ** 2
    heights = np.where(footprint, rng.standard_normal((n, n)) * 1e-6, np.nan)
    return Topography(heights, 1e-4, footprint=footprint, metadata={"seed": seed})


def scattered(topography: Topography, comm) -> TopographyRows:
    """Rank 0 hands its topography out; the other ranks pass None (they need not have it)."""
    return TopographyRows.scatter(topography if comm.Get_rank() == 0 else None, comm)


@pytest.mark.parametrize("n", [1, 7, 40])
def test_scatter_gives_each_rank_its_rows_of_the_whole_topography(comm, n):
    """Heights and mask bit for bit, rows as the operators split them, the per-row footprint counts
    and the nominal area of the whole topography."""
    whole = disc_topography(n) if n > 1 else Topography(np.ones((1, 1)), 1e-4)
    rows = scattered(whole, comm)
    start, stop = split(n, comm.Get_size())[comm.Get_rank()]
    assert rows.rows == (start, stop) and rows.shape == whole.shape and rows.spacing == whole.spacing
    np.testing.assert_array_equal(rows.local_footprint, whole.footprint[start:stop])
    np.testing.assert_array_equal(rows.local_heights[rows.local_footprint], whole.heights[start:stop][whole.footprint[start:stop]])
    np.testing.assert_array_equal(rows.row_counts, whole.row_counts)
    assert rows.nominal_area == whole.nominal_area and rows.footprint_nodes == whole.footprint_nodes
    assert rows.metadata == whole.metadata


@pytest.mark.parametrize("source", ["rows", "whole"])
@pytest.mark.parametrize("n", [40, 41, 130])
def test_decimated_rows_are_the_rows_of_the_decimated_topography(comm, n, source):
    """Every other node, redistributed to the coarse grid's rows (each rank's coarse rows come from
    fine rows that other ranks may hold): coarsen(topography, 2, "decimate") cut into rows, bit for
    bit, for even and odd n; from rows, and from a whole topography on every rank (the nested
    start's coarse grid, :func:`roughcontact.normal.nested.decimated_rows`)."""
    from roughcontact.normal.nested import decimated_rows

    whole = disc_topography(n)
    coarse = coarsen(whole, 2, "decimate")
    rows = scattered(whole, comm).decimated(comm) if source == "rows" else decimated_rows(whole, comm)
    start, stop = split(coarse.shape[0], comm.Get_size())[comm.Get_rank()]
    assert rows.rows == (start, stop) and rows.shape == coarse.shape and rows.spacing == coarse.spacing
    np.testing.assert_array_equal(rows.local_footprint, coarse.footprint[start:stop])
    np.testing.assert_array_equal(rows.local_heights[rows.local_footprint], coarse.heights[start:stop][coarse.footprint[start:stop]])
    np.testing.assert_array_equal(rows.row_counts, coarse.row_counts)
    assert rows.metadata["coarsening"] == coarse.metadata["coarsening"]


@pytest.mark.parametrize("operator,n", [("fft", 192), ("dense", 30)])
def test_a_solve_on_rows_is_the_solve_on_the_whole_topography(comm, operator, n):
    """The same nodes on the same ranks and, at 192² (a disc of 18 530 nodes > 4 × 64², so the fft
    solve starts from a coarse grid decimated by rows), the same coarse start: forces, contact set,
    gap and every scalar bit for bit, by rows and gathered. The dense operator gathers the
    footprint's mask for its assembly (N bytes, on the small grids it is chosen for)."""
    whole_topography = disc_topography(n)
    load = 2e-4 * whole_topography.nominal_area * ROCK.contact_modulus
    results = []
    for topography in (whole_topography, scattered(whole_topography, comm)):
        with NormalProblem(topography, ROCK, comm, operator=operator) as problem, \
                make_solver(problem, "cg") as solver:
            results.append((solver.solve_load(load, rotation=(0.0, 0.0), gather=False),
                            solver.solve_load(1.5 * load, rotation=(0.0, 0.0))))
    (rows_a, gathered_a), (rows_b, gathered_b) = results
    assert rows_a.coarse_iterations == rows_b.coarse_iterations
    if operator == "fft":
        assert rows_a.coarse_iterations > 0          # the coarse start ran, on the decimated rows
    for a, b in ((rows_a, rows_b), (gathered_a, gathered_b)):
        assert a.rows == b.rows
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        for name in ("load", "closure", "moments", "centroid", "contact_area", "linear_iterations", "residual"):
            assert getattr(a, name) == getattr(b, name), name


def test_rows_with_a_bad_block_raise_the_same_error_on_every_rank(comm):
    """A rank whose heights are not its rows (or carry NaN on the footprint) makes every rank raise
    the same one-line InputError, naming that rank: none waits in a collective call."""
    n, rank = 12, comm.Get_rank()
    start, stop = split(n, comm.Get_size())[rank]
    good = np.zeros((stop - start, n))
    last = comm.Get_size() - 1
    heights = np.zeros((stop - start + 1, n)) if rank == last else good
    with pytest.raises(InputError, match=rf"^heights: holds shape .* \(rank {last}\)$"):
        TopographyRows.from_rows(heights, 1e-4, (n, n), comm)
    heights = good.copy()
    if rank == last:
        heights[0, 0] = np.nan
    with pytest.raises(InputError, match=rf"^heights: 1 node\(s\) of the footprint are NaN .* \(rank {last}\)$"):
        TopographyRows.from_rows(heights, 1e-4, (n, n), comm)
    mask = np.ones_like(good, dtype=bool)
    mask[0, 0] = rank != last
    rows = TopographyRows.from_rows(heights, 1e-4, (n, n), comm, footprint=mask)   # NaN off the footprint
    assert rows.footprint_nodes == n * n - 1


def test_unreadable_rows_or_a_root_without_a_topography_raise_on_every_rank(comm):
    """Heights numpy cannot read as numbers on one rank, or a root handing out something that is not
    a Topography: every rank raises the same one-line InputError (none is left in a collective)."""
    n, rank = 12, comm.Get_rank()
    start, stop = split(n, comm.Get_size())[rank]
    last = comm.Get_size() - 1
    heights = [["a"] * n] * (stop - start) if rank == last else np.zeros((stop - start, n))
    with pytest.raises(InputError, match=rf"^heights: cannot be read as numbers .* \(rank {last}\)$"):
        TopographyRows.from_rows(heights, 1e-4, (n, n), comm)
    with pytest.raises(InputError, match=r"^topography: must be a Topography on rank 0, got ndarray$"):
        TopographyRows.scatter(np.zeros((n, n)) if rank == 0 else None, comm)


def test_a_whole_result_of_another_grid_is_refused_as_a_warm_start(comm):
    """warm_start slices each rank's rows out of a whole result: one of another grid is refused on
    every rank in one line, instead of rows that happen to fit on some ranks."""
    with NormalProblem(disc_topography(40), ROCK, comm, operator="fft") as other, make_solver(other, "cg") as solver:
        foreign = solver.solve_load(1e-4 * other.topography.nominal_area * ROCK.contact_modulus, rotation=(0.0, 0.0))
    with NormalProblem(disc_topography(36), ROCK, comm, operator="fft") as problem, \
            make_solver(problem, "cg") as solver:
        with pytest.raises(InputError, match=r"^result: holds a 40 x 40 grid, this problem's is 36 x 36"):
            solver.warm_start(foreign)


def test_rows_of_another_communicator_are_refused_in_one_line(comm):
    """Rows split over this communicator, handed to a problem on a communicator of another size."""
    if comm.Get_size() == 1:
        pytest.skip("needs two ranks: one rank's rows are the whole grid on any communicator of one")
    rows = scattered(disc_topography(20), comm)
    with pytest.raises(InputError, match="^topography: holds rows split over another number of ranks"):
        NormalProblem(rows, ROCK, MPI.COMM_SELF, operator="fft")


def test_what_needs_the_whole_topography_says_so(comm):
    """A tangential solve, or a whole field from node values, on a topography held by rows."""
    with NormalProblem(scattered(disc_topography(40), comm), ROCK, comm, operator="fft") as problem:
        with make_solver(problem, "cg") as solver:
            normal = solver.solve_load(1e-4 * problem.topography.nominal_area * ROCK.contact_modulus,
                                       rotation=(0.0, 0.0))
        with pytest.raises(InputError, match=r"^topography: is held by rows \(TopographyRows\); a tangential "
                                             r"solve needs the whole Topography on every rank$"):
            CattaneoSolver(problem, normal, 0.5)
        with pytest.raises(InputError, match="^topography: is held by rows"):
            problem.to_field(np.zeros(problem.local_size))


def test_a_solve_on_rows_holds_memory_that_divides_over_the_ranks(comm):
    """Traced allocations (tracemalloc: deterministic, unlike the resident set) of handing out the
    surface, building the problem and a cold solve (nested start, gather=False) at 256²: with the
    surface by rows the peak on each of k ranks is at most 1/k + 0.02 of one rank's (measured
    0.501, 0.339, 0.255 on 2, 3, 4 ranks; the 0.02 is the FFT plans, the transposes' datatypes and
    the small coarse levels, which do not divide). A whole Topography made on every rank instead
    measured 0.519, 0.354 and 0.282: over the bound from three ranks on (the surface is 9 B/node
    against the solve's ~300, so on two ranks it stays within 0.02). Rank 0's input array exists
    before the count starts."""
    if comm.Get_size() == 1:
        pytest.skip("needs more than one rank")
    n = 256
    whole = Topography(np.random.default_rng(1).standard_normal((n, n)) * 1e-6, 1e-4)
    load = 1e-3 * whole.nominal_area * ROCK.contact_modulus

    def solve(on) -> None:
        topography = TopographyRows.scatter(whole if on.Get_rank() == 0 else None, on)
        with NormalProblem(topography, ROCK, on, operator="fft") as problem, make_solver(problem, "cg") as solver:
            assert solver.solve_load(load, rotation=(0.0, 0.0), gather=False).coarse_iterations > 0

    share, ranks = traced_share(comm, solve), comm.Get_size()
    assert share <= 1.0 / ranks + 0.02, (share, ranks)


def test_each_rank_reads_its_rows_of_a_topography_file(comm, shared_dir):
    """A file of write_topography read by rows is the topography handed out from rank 0, bit for
    bit (heights, mask, spacing, metadata); a missing or foreign file raises one line everywhere."""
    from roughcontact.surfaces import read_topography, write_topography

    whole = disc_topography(37)
    path = shared_dir / "surface.nc"
    if comm.Get_rank() == 0:
        write_topography(whole, path)
        with open(shared_dir / "other.nc", "wb") as handle:
            handle.write(b"not HDF5")
    comm.Barrier()
    read, handed = TopographyRows.read(path, comm), scattered(whole, comm)
    assert (read.shape, read.rows, read.spacing) == (handed.shape, handed.rows, handed.spacing)
    np.testing.assert_array_equal(read.local_footprint, handed.local_footprint)
    np.testing.assert_array_equal(read.local_heights[read.local_footprint], handed.local_heights[handed.local_footprint])
    np.testing.assert_array_equal(read.row_counts, handed.row_counts)
    assert read.metadata["stored_metadata"] == {"seed": 5}
    expected = read_topography(path).metadata             # the whole reader's, but the file's hash
    assert read.metadata == {k: v for k, v in expected.items() if k != "sha256"}
    for name in ("missing.nc", "other.nc"):
        with pytest.raises(InputError, match=rf"^path: {name}: not a topography file of write_topography"):
            TopographyRows.read(shared_dir / name, comm)
