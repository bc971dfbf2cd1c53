"""A solve with ``gather=False`` leaves each rank its own grid rows of the fields: the same numbers
as the gathered result, cut into the ranks' rows; written to one file from those rows, the file is
the sweep dataset of the gathered result; what needs whole fields refuses it in one line."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from mpi4py import MPI

from roughcontact.analysis.inputs import as_dataset
from roughcontact.datasets import normal_sweep_dataset
from roughcontact.errors import InputError
from roughcontact.materials import Interface, Material
from roughcontact.normal import NormalProblem, gather_result, make_solver, write_result
from roughcontact.surfaces import Topography
from roughcontact.tangential import CattaneoSolver

ROCK = Interface(Material(30e9, 0.25))
FIELDS = ("force", "pressure", "contact", "gap")


def disc_problem(comm, operator: str = "fft", n: int = 40) -> NormalProblem:
    """Random heights on a disc-shaped footprint: rows of unequal length, NaN outside."""
    rng = np.random.default_rng(5)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    footprint = (i - 0.45 * n) ** 2 + (j - 0.55 * n) ** 2 <= (0.4 * n) ** 2
    heights = np.where(footprint, rng.standard_normal((n, n)) * 1e-6, np.nan)
    return NormalProblem(Topography(heights, 1e-4, footprint=footprint), ROCK, comm, operator=operator)


def solve_both(problem, load: float = 0.05):
    """The same load-controlled solve, gathered and by rows, each from a cold start."""
    with make_solver(problem, "auto") as solver:
        whole = solver.solve_load(load, rotation=(0.0, 0.0))
    with make_solver(problem, "auto") as solver:
        rows = solver.solve_load(load, rotation=(0.0, 0.0), gather=False)
    return whole, rows


@pytest.mark.parametrize("operator", ["fft", "dense"])
def test_rows_are_the_gathered_fields_cut_into_each_ranks_rows(comm, operator):
    """Bit for bit (the solve is the same; only where its fields are assembled differs), on
    every rank; the rows of all ranks tile the grid; the load is the sum of the rows' forces
    over the ranks (to round-off of the summation order, 1e-12)."""
    problem = disc_problem(comm, operator)
    whole, rows = solve_both(problem)
    assert whole.rows is None and rows.distributed
    start, stop = rows.rows
    assert (start, stop) == tuple(problem.flexibility.layout.rows)
    tiles = comm.allgather((start, stop))
    assert tiles[0][0] == 0 and tiles[-1][1] == problem.topography.shape[0]
    assert all(a[1] == b[0] for a, b in zip(tiles, tiles[1:]))
    for name in FIELDS:
        assert getattr(rows, name).shape == (stop - start, problem.topography.shape[1])
        np.testing.assert_array_equal(getattr(rows, name), getattr(whole, name)[start:stop], err_msg=name)
    for name in ("load", "closure", "moments", "centroid", "contact_area", "linear_iterations", "residual"):
        assert getattr(rows, name) == getattr(whole, name), name
    assert rows.contact_count == whole.contact_count == comm.allreduce(int(rows.contact.sum()))
    assert comm.allreduce(float(rows.force.sum())) == pytest.approx(whole.load, rel=1e-12)
    gathered = gather_result(rows, problem)
    assert gathered.rows is None
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(gathered, name), getattr(whole, name), err_msg=name)
    assert gather_result(whole, problem) is whole
    problem.destroy()


def test_the_written_file_is_the_sweep_dataset_of_the_gathered_result(comm, shared_dir):
    """Rank 0 receives one rank's rows at a time; the file equals, variable for variable, the
    dataset of the whole result written through xarray (the solve's wall time aside: two solves)."""
    problem = disc_problem(comm)
    whole, rows = solve_both(problem)
    from_rows = write_result(rows, problem, shared_dir / "rows.nc")
    from_whole = write_result(whole, problem, shared_dir / "whole.nc")
    assert not list(shared_dir.glob("*.part"))
    # the wall time is each rank's own: the file has rank 0's
    expected = normal_sweep_dataset([whole], problem.topography.spacing, dim="step").drop_vars("elapsed")
    with xr.open_dataset(from_whole) as a, xr.open_dataset(from_rows) as b:
        assert float(a.elapsed[0]) == comm.bcast(whole.elapsed, root=0)
        xr.testing.assert_identical(a.load().drop_vars("elapsed"), expected)
        xr.testing.assert_identical(b.load().drop_vars("elapsed"), expected)
    only_contact = write_result(rows, problem, shared_dir / "contact.nc", fields="contact")
    with xr.open_dataset(only_contact) as c:
        assert [v for v in c.data_vars if "x" in c[v].dims] == ["contact"]
        np.testing.assert_array_equal(c.contact.values[0], whole.contact.astype(np.int8))
    problem.destroy()


def test_a_failed_write_raises_on_every_rank_and_leaves_no_file(comm, shared_dir):
    """Rank 0 cannot create the directory (a file of that name is in the way): every rank gets the
    same OSError — the other ranks' rows are still received, so no rank waits — and nothing is left."""
    problem = disc_problem(comm)
    _, rows = solve_both(problem)
    blocker = shared_dir / "blocker"
    if comm.Get_rank() == 0:
        blocker.write_text("not a directory")
    comm.Barrier()
    with pytest.raises(OSError, match="could not write"):
        write_result(rows, problem, blocker / "out.nc")
    assert comm.allreduce(1) == comm.Get_size()          # every rank came back
    assert sorted(p.name for p in shared_dir.iterdir()) == ["blocker"]
    problem.destroy()


def test_whole_grid_consumers_refuse_rows_in_one_line(comm):
    problem = disc_problem(comm)
    whole, rows = solve_both(problem)
    with pytest.raises(InputError, match="gather_result"):
        CattaneoSolver(problem, rows, 0.5)
    with pytest.raises(InputError, match="gather_result"):
        as_dataset(rows)
    with pytest.raises(InputError, match="gather_result"):
        normal_sweep_dataset([rows], problem.topography.spacing)
    scalars = normal_sweep_dataset([rows], problem.topography.spacing, fields="none")
    assert float(scalars.normal_load[0]) == whole.load
    with make_solver(problem, "auto") as solver, pytest.raises(InputError, match="gather"):
        solver.solve_load(0.05, rotation=(0.0, 0.0), gather="no")
    problem.destroy()


def test_a_warm_start_from_rows_is_the_warm_start_from_the_whole_result(comm):
    """Both give the solver the same forces, set and motion: the next load's solve is the same,
    bit for bit, and restarting at the solved load needs at most one iteration."""
    problem = disc_problem(comm)
    whole, rows = solve_both(problem)
    results = []
    for start in (whole, rows):
        with make_solver(problem, "cg") as solver:
            solver.warm_start(start)
            again = solver.solve_load(0.05, rotation=(0.0, 0.0))
            assert again.linear_iterations <= 1
            results.append(solver.solve_load(0.08, rotation=(0.0, 0.0)))
    np.testing.assert_array_equal(results[0].force, results[1].force)
    other = disc_problem(MPI.COMM_SELF, n=40)
    if comm.Get_size() > 1:
        with make_solver(other, "cg") as solver, pytest.raises(InputError, match="another problem"):
            solver.warm_start(rows)
    other.destroy()
    problem.destroy()


@pytest.mark.parametrize("needed", [(0, 0), (0, 1), (3, 17), (10, 40), (0, 40), (39, 40)])
def test_a_window_of_rows_is_the_whole_fields_rows(comm, needed):
    """Any window of rows, wherever the ranks' blocks start and end, is the whole field's, bit for
    bit; each rank asks for its own window (here shifted by its rank, so windows overlap blocks of
    several ranks)."""
    from roughcontact.surfaces.rows import rows_window, split

    whole = np.random.default_rng(7).standard_normal((40, 9))
    rows = split(40, comm.Get_size())[comm.Get_rank()]
    start = min(needed[0] + comm.Get_rank(), needed[1])
    window = (start, needed[1])
    got = rows_window(whole[rows[0]:rows[1]].copy(), rows, window, comm)
    np.testing.assert_array_equal(got, whole[window[0]:window[1]])


def test_the_prolongation_from_rows_is_the_one_from_the_gathered_coarse_result(comm):
    """The nested start's coarse solve keeps its fields by rows; the fine forces it prolongs are
    those of the gathered coarse result, bit for bit (each rank receives only the coarse rows
    between which its fine rows fall)."""
    from roughcontact.normal.nested import prolong
    from roughcontact.surfaces import coarsen

    fine = disc_problem(comm, n=41)
    coarse = NormalProblem(coarsen(fine.topography, 2, "decimate"), ROCK, comm, operator="fft")
    with make_solver(coarse, "cg") as solver:
        rows = solver.solve_load(0.05, rotation=(0.0, 0.0), gather=False)
    whole = gather_result(rows, coarse)
    np.testing.assert_array_equal(prolong(rows, coarse, fine), prolong(whole, coarse, fine))
    assert comm.allreduce(float(prolong(rows, coarse, fine).sum())) > 0.0
    coarse.destroy()
    fine.destroy()
