"""The ensemble farm: the same numbers as solving each task alone, on any layout, with labels.

Run serially and under ``mpiexec -n 2``: with two ranks the farm is a real
``mpi4py.futures`` farm of two groups (or one group of two ranks), and every
assertion is checked on every rank against the combined file rank 0 wrote.
Small tasks (17 × 17 nodes, three loads) keep the file quick.
"""
from __future__ import annotations

import random

import numpy as np
import pytest
import xarray as xr
from mpi4py import MPI

from roughcontact.errors import ConvergenceError, InputError
from roughcontact.farm import load_study, run_study, solve_task
from roughcontact.farm.records import task_groups
from roughcontact.farm.store import TaskStore


def tiny(name: str = "tiny-ensemble", **tables) -> dict:
    """2 Δ × 3 seeds on 17² nodes, three loads, a Q sweep and a fretting cycle at the largest.
    ν = 0 bodies: the Cattaneo analogy is exact (β = γ = 0), so no approximation warning."""
    raw = {"name": name,
           "surface": {"generator": "midpoint", "levels": 4, "spacing": 1e-4, "rms_height": 1e-5},
           "axes": {"fractal_dimension": [2.2, 2.4], "seeds": 3},
           "materials": {"body1": {"E": 20e9, "nu": 0.0}, "body2": {"E": 20e9, "nu": 0.0}},
           "normal": {"loads": [2.0, 5.0, 10.0]},
           "tangential": {"friction": 0.5, "steps": 3, "at": [10.0], "fretting_amplitude": 0.5},
           "output": {"fields": "all"}}
    raw.update(tables)
    return raw


def quiet(*args, **kwargs):
    pass


def open_group(path, group=None):
    with xr.open_dataset(path, engine="h5netcdf", group=group) as ds:
        return ds.load()


def timing(name: str) -> bool:
    """Wall times differ from run to run; everything else must not."""
    return "elapsed" in name


def assert_task_matches(groups: dict, combined: dict, study, task) -> None:
    """Every variable of a task's own datasets equals its slice of the combined dataset, bit for bit."""
    where = dict(zip((d.name for d in study.dimensions), task.position))
    for name, ds in groups.items():
        part = combined[name].isel(where)
        for var in ds.data_vars:
            if timing(var):
                continue
            mine = ds[var].values
            theirs = part[var].values[tuple(slice(0, n) for n in mine.shape)]
            np.testing.assert_array_equal(mine, theirs, err_msg=f"{task.name}, {name}/{var}")


def test_farm_equals_tasks_solved_one_by_one(comm, shared_dir):
    """The combined dataset holds, at each task's place, exactly what solving that task alone
    on one rank gives (bitwise: with one rank per task the arithmetic is the same), whatever
    the order the farm took the tasks in; and equilibrium holds (Σ p̄ = P to 1e-8, the
    tolerance load control guarantees, ActiveSetSettings.load_tol)."""
    study = load_study(tiny())
    summary = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    assert summary.exit_code == 0 and summary.solved == 6 and not summary.failed
    path = summary.paths["netcdf"]
    combined = {g: open_group(path, None if g == "/" else g) for g in ("/", "tangential", "fretting")}
    root = combined["/"]
    assert root.sizes == {"fractal_dimension": 2, "seed": 3, "normal_load": 3, "x": 17, "y": 17}
    assert list(root["seed"].values) == [1, 2, 3]
    np.testing.assert_allclose(root["force"].sum(("x", "y")), np.broadcast_to([2.0, 5.0, 10.0], (2, 3, 3)),
                               rtol=1e-8)
    assert root["normal_load"].attrs["units"] == "N" and "load" not in root.variables
    assert (root["status"] == 0).all()
    tasks = study.tasks()
    random.Random(comm.Get_rank()).shuffle(tasks)        # another order on each rank
    for task in tasks[:3]:
        assert_task_matches(task_groups(solve_task(task, MPI.COMM_SELF)), combined, study, task)
    # the tangential group is labelled by Q / fP and carries Q = (Q/fP) f P as a coordinate
    tangential = combined["tangential"]
    np.testing.assert_array_equal(tangential["Q_over_fP"], [0.0, 1 / 3, 2 / 3, 1.0])
    np.testing.assert_allclose(tangential["Q"].sel(normal_load=10.0), [0.0, 5 / 3, 10 / 3, 5.0], rtol=1e-15)
    assert tangential["stick_area"].sel(normal_load=2.0).isnull().all()   # no sweep asked at 2 N
    assert tangential["limit"].sel(normal_load=10.0, Q_over_fP=1.0).all()


def test_warnings_of_a_task_reach_the_combined_dataset(comm, shared_dir, monkeypatch):
    """ν = 0.2 bodies: a tangential sweep is the uncoupled approximation and warns (once per
    process). The warning is in the warnings variable of the task that raised it, and the
    closing line counts the tasks with warnings."""
    from roughcontact.tangential import model

    monkeypatch.setattr(model, "_warned", set())
    lines = []
    study = load_study(tiny(name="warning", axes={"seeds": 2},
                            surface={"generator": "midpoint", "levels": 3, "spacing": 1e-4, "rms_height": 1e-5,
                                     "fractal_dimension": 2.3},
                            materials={"body1": {"E": 20e9, "nu": 0.2}, "body2": {"E": 20e9, "nu": 0.2}},
                            normal={"loads": [5.0]}, tangential={"friction": 0.5, "steps": 2}))
    summary = run_study(study, comm, shared_dir, log=lines.append, quiet=True)
    assert summary.exit_code == 0
    texts = [str(t) for t in open_group(summary.paths["netcdf"])["warnings"].values]
    warned = [t for t in texts if t]
    assert warned and all(t.startswith("UncoupledApproximationWarning: ") for t in warned), texts
    assert summary.warned == len(warned)
    if comm.Get_rank() == 0:
        assert f"0 failed, {len(warned)} with warnings (see the variable warnings)" in lines[-1]


def test_one_or_two_ranks_per_task_agree(comm, shared_dir):
    """Two groups of one rank and one group of two ranks solve the same tasks: the operator
    rows are split differently, so sums are rounded differently; each state meets its load to
    the load-control tolerance 1e-8, so the two agree to 2e-8 (δz grows slower than P), and
    the contact sets node for node."""
    study = load_study(tiny(name="layout", tangential={}))
    if comm.Get_size() % 2:
        with pytest.raises(InputError) as info:
            run_study(study, comm, shared_dir, log=quiet, ranks_per_task=2)
        assert info.value.parameter == "farm.ranks_per_task"
        return
    one = run_study(study, comm, shared_dir / "k1", log=quiet, quiet=True, ranks_per_task=1)
    two = run_study(study, comm, shared_dir / "k2", log=quiet, quiet=True, ranks_per_task=2)
    a, b = open_group(one.paths["netcdf"]), open_group(two.paths["netcdf"])
    assert a.attrs["ranks_per_task"] == 1 and b.attrs["ranks_per_task"] == 2
    np.testing.assert_array_equal(a["contact"], b["contact"])
    for var in ("closure", "contact_fraction", "centroid_x", "mean_pressure"):
        np.testing.assert_allclose(a[var], b[var], rtol=2e-8, err_msg=var)


def test_failed_task_is_recorded_and_the_rest_complete(comm, shared_dir, monkeypatch):
    """A solver failure inside one task keeps that task's solved loads and its message, the
    other tasks complete, and the run says so; a second run does not retry it unless asked."""
    from roughcontact.normal import NormalSolver

    solve_load = NormalSolver.solve_load

    def fail(self, load, *args, **kwargs):     # the same decision on every rank of the task
        meta = self.problem.topography.metadata
        if meta.get("seed") == 2 and meta.get("fractal_dimension") == 2.4 and load == 5.0:
            raise ConvergenceError("ACTIVE_SET_MAX_ITERATIONS", "forced for the test")
        return solve_load(self, load, *args, **kwargs)

    monkeypatch.setattr(NormalSolver, "solve_load", fail)
    study = load_study(tiny(name="failing", tangential={}))
    summary = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    assert summary.exit_code == 1 and list(summary.failed) == [4]          # (Δ = 2.4, seed 2)
    assert "ACTIVE_SET_MAX_ITERATIONS" in summary.failed[4]
    ds = open_group(summary.paths["netcdf"])
    failed = ds.sel(fractal_dimension=2.4, seed=2)
    assert int(failed["status"]) == 1 and "forced for the test" in str(failed["message"].values)
    assert np.isfinite(failed["closure"].sel(normal_load=2.0))                # solved before the failure
    assert failed["closure"].sel(normal_load=[5.0, 10.0]).isnull().all()
    assert (failed["contact"].sel(normal_load=10.0) == -1).all()             # int8 "not computed"
    assert int((ds["status"] == 0).sum()) == 5 and ds["closure"].count() == 5 * 3 + 1
    again = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    assert again.solved == 0 and again.resumed == 6 and list(again.failed) == [4]
    monkeypatch.setattr(NormalSolver, "solve_load", solve_load)
    retried = run_study(study, comm, shared_dir, log=quiet, quiet=True, retry_failed=True)
    assert retried.solved == 1 and retried.exit_code == 0


@pytest.mark.parametrize("k", [1, 2])
def test_a_task_past_its_timeout_stops_at_the_next_load_and_keeps_what_it_solved(comm, shared_dir, k):
    """``[farm] task_timeout`` of 1 ns has always passed once the first load is solved: every task
    keeps that load, stops before the second with a TaskTimeout naming the limit and is recorded
    failed; on a group of two ranks both stop at the same load (no hang). Run again with a long
    limit and --retry-failed, the tasks are solved whole and equal a run without a limit."""
    if comm.Get_size() % k:
        pytest.skip("k must divide the ranks")
    study = load_study(tiny(name="late", tangential={}, farm={"ranks_per_task": k, "task_timeout": 1e-9}))
    summary = run_study(study, comm, shared_dir / "late", log=quiet, quiet=True)
    assert summary.exit_code == 1 and sorted(summary.failed) == list(range(6))
    assert all(m.startswith("TaskTimeout: [farm] task_timeout of 1e-09 s passed after 1 of 3 load(s)")
               for m in summary.failed.values()), summary.failed
    ds = open_group(summary.paths["netcdf"])
    assert (ds["status"] == 1).all()
    assert np.isfinite(ds["closure"].sel(normal_load=2.0)).all()
    assert ds["closure"].sel(normal_load=[5.0, 10.0]).isnull().all()
    patient = load_study(tiny(name="late", tangential={}, farm={"ranks_per_task": k, "task_timeout": 1e6}))
    retried = run_study(patient, comm, shared_dir / "late", log=quiet, quiet=True, retry_failed=True)
    assert retried.solved == 6 and retried.exit_code == 0
    fresh = run_study(load_study(tiny(name="late", tangential={}, farm={"ranks_per_task": k})), comm,
                      shared_dir / "fresh", log=quiet, quiet=True)
    a, b = open_group(retried.paths["netcdf"]), open_group(fresh.paths["netcdf"])
    for var in ("closure", "contact_fraction", "contact"):
        np.testing.assert_array_equal(a[var], b[var], err_msg=var)


def test_resume_recomputes_only_missing_tasks(comm, shared_dir):
    """Deleting two task files (and leaving a torn ``.part``) makes the next run solve exactly
    those two; the other files are not rewritten and the result is the same, bit for bit."""
    study = load_study(tiny(name="resume", tangential={}, output={"fields": "contact"}))
    first = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    store = TaskStore(shared_dir, study.name)
    before = open_group(first.paths["netcdf"])
    comm.Barrier()
    tasks = study.tasks()
    if comm.Get_rank() == 0:
        for index in (1, 4):
            store.path(tasks[index]).unlink()
        store.path(tasks[3]).with_name(store.path(tasks[3]).name + ".part").write_bytes(b"torn write")
    kept = {i: store.path(tasks[i]).stat().st_mtime_ns for i in (0, 2, 3, 5)}
    comm.Barrier()
    second = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    assert second.solved == 2 and second.resumed == 4
    assert {i: store.path(tasks[i]).stat().st_mtime_ns for i in kept} == kept
    assert not list(store.directory.glob("*.part"))
    after = open_group(second.paths["netcdf"])
    for var in before.data_vars:
        if not timing(var):
            np.testing.assert_array_equal(before[var].values, after[var].values, err_msg=var)


def test_changed_study_under_the_same_name_is_refused(comm, shared_dir):
    run_study(load_study(tiny(name="same", tangential={}, axes={"fractal_dimension": [2.3], "seeds": 1})), comm, shared_dir,
              log=quiet, quiet=True)
    changed = load_study(tiny(name="same", tangential={}, axes={"fractal_dimension": [2.3], "seeds": 1},
                              normal={"loads": [2.0, 5.0, 20.0]}))
    with pytest.raises(InputError, match="other values of normal.loads.*Only axes may change") as info:
        run_study(changed, comm, shared_dir, log=quiet, quiet=True)
    assert info.value.parameter == "normal.loads"
    # the description and the rank layout are not part of the definition
    renamed = load_study({**tiny(name="same", tangential={}, axes={"fractal_dimension": [2.3], "seeds": 1}), "description": "new words",
                          "farm": {"ranks_per_task": 1}})
    assert run_study(renamed, comm, shared_dir, log=quiet, quiet=True).resumed == 1


def test_pressures_zip_and_shift_axes(comm, shared_dir):
    """Loads given as σ0 = P/A0 mean the same on every footprint; zipped axes share one
    dimension; mated shifts label a ``shift`` dimension; fields of grids that differ in spacing
    start at node (0, 0) of a grid as large as the largest, −1 outside each task's own."""
    raw = tiny(name="axes", tangential={}, axes={"levels": [3, 4], "spacing": [2e-4, 1e-4],
                                                 "mate_shift": [[1e-4, 0.0], [3e-4, 0.0]],
                                                 "zip": ["levels", "spacing"]},
               normal={"pressures": [1e5, 3e5]}, output={"fields": "contact"})
    raw["surface"] = {"generator": "midpoint", "rms_height": 1e-5, "fractal_dimension": 2.3, "seed": 5}
    study = load_study(raw)
    assert [d.name for d in study.dimensions] == ["levels", "shift"]
    summary = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    ds = open_group(summary.paths["netcdf"])
    assert dict(ds.sizes) == {"levels": 2, "shift": 2, "mean_pressure": 2, "x": 16, "y": 17}
    np.testing.assert_array_equal(ds["spacing"], [2e-4, 1e-4])            # a coordinate on "levels"
    np.testing.assert_array_equal(ds["shift_x"], [1e-4, 3e-4])
    # P = σ0 A0 to the load tolerance (1e-8); A0 = (footprint nodes) s²
    imposed = (ds["mean_pressure"] * ds["nominal_area"]).transpose(*ds["normal_load"].dims)
    np.testing.assert_allclose(ds["normal_load"], imposed, rtol=1e-8)
    np.testing.assert_allclose(ds["nominal_area"], ds["footprint_nodes"] * ds["grid_spacing"] ** 2, rtol=1e-15)
    assert "differ in spacing" in ds.attrs["fields_note"] and "x" not in ds.coords
    for index, task in enumerate(study.tasks()):
        where = dict(zip(("levels", "shift"), task.position))
        with xr.open_dataset(TaskStore(shared_dir, "axes").path(task), engine="h5netcdf") as own:
            nx, ny = own.sizes["x"], own.sizes["y"]
            combined = ds["contact"].isel(where).values
            np.testing.assert_array_equal(combined[:, :nx, :ny], own["contact"].values)
            assert (combined[:, nx:, :] == -1).all() and (combined[:, :, ny:] == -1).all()
            assert own["contact"].dtype == np.int8 and own.attrs["axis_levels"] == [3, 4][task.position[0]]


def test_shifted_lenses_share_the_frame_of_the_uncut_face(comm, shared_dir):
    """Mated shifts crop each composite to its own lens: the combined fields lie in the frame of
    the face before cropping, each task's at its origin (node i of a task is node i + origin/s of
    the frame), NaN outside its lens; x is that frame's coordinate at the task's origin; the finite
    gaps of a task are its footprint's nodes. Checked against the task files bit for bit."""
    shifts = [[-2e-4, 0.0], [3e-4, 1e-4]]
    raw = tiny(name="lenses", tangential={}, axes={"mate_shift": shifts}, normal={"loads": [1e-3, 1.0]},
               surface={"generator": "midpoint", "levels": 4, "spacing": 1e-4, "rms_height": 1e-5,
                        "fractal_dimension": 2.3, "seed": 4, "footprint_diameter": 1.5e-3})
    study = load_study(raw)
    summary = run_study(study, comm, shared_dir, log=quiet, quiet=True)
    ds = open_group(summary.paths["netcdf"])
    assert "differ in extent" in ds.attrs["fields_note"]
    s = 1e-4
    for index, task in enumerate(study.tasks()):
        with xr.open_dataset(TaskStore(shared_dir, "lenses").path(task), engine="h5netcdf") as own:
            i0 = int(round((float(own["origin_x"]) - float(ds["x"][0])) / s))
            j0 = int(round((float(own["origin_y"]) - float(ds["y"][0])) / s))
            nx, ny = own.sizes["x"], own.sizes["y"]
            placed = ds["gap"].isel(shift=index)
            np.testing.assert_array_equal(placed.values[:, i0:i0 + nx, j0:j0 + ny], own["gap"].values)
            outside = np.ones(placed.shape[1:], bool)
            outside[i0:i0 + nx, j0:j0 + ny] = False
            assert np.isnan(placed.values[:, outside]).all()
            np.testing.assert_allclose(float(ds["x"][i0]), float(own["origin_x"]), rtol=0, atol=1e-12)
            assert np.isfinite(own["gap"].values[0]).sum() == int(own["footprint_nodes"])


def test_task_files_read_back_as_written(comm):
    """The task file writer (h5py with netCDF-4's conventions) gives, through xarray, exactly the
    datasets it was handed: numbers, int8 fields, strings, auxiliary coordinates and groups; also
    for a task that failed before its first load (an InputError raised inside the task: a mated
    shift larger than the surface leaves no overlap)."""
    import io

    from roughcontact.farm.records import encode
    from roughcontact.netcdf import netcdf_attrs

    study = load_study(tiny(name="files", axes={"mate_shift": [[1e-4, 0.0], [5e-3, 0.0]]},
                            surface={"generator": "midpoint", "levels": 4, "spacing": 1e-4, "rms_height": 1e-5,
                                     "fractal_dimension": 2.3, "seed": 1}))
    completed, failed = (solve_task(task, MPI.COMM_SELF) for task in study.tasks())
    assert completed.error is None and failed.error.startswith("InputError: shift")
    for outcome in (completed, failed):
        groups = task_groups(outcome)
        data = encode(groups)
        for name, ds in groups.items():
            with xr.open_dataset(io.BytesIO(data), engine="h5netcdf", group=None if name == "/" else name) as back:
                expected = ds.copy()
                expected.attrs = netcdf_attrs(ds.attrs)
                xr.testing.assert_identical(back.load(), expected)
    assert set(task_groups(failed)) == {"/"}


def test_what_a_leader_hands_rank_0_is_what_its_file_reads_back(comm):
    """A leader sends rank 0 its task's small variables from memory (``held_groups``) instead of
    reading its file back: for a task with tangential and fretting groups, fields "all", and a
    task that failed before its first load, they equal what the file reads back without fields
    (names and their order, dimensions, coordinates, dtypes, values bit for bit, attributes), so a
    study combined from finished tasks and from files on resume is one dataset."""
    from roughcontact.farm.netcdf import Unread, held_groups, read_groups
    from roughcontact.farm.records import encode

    study = load_study(tiny(name="held", axes={"mate_shift": [[1e-4, 0.0], [5e-3, 0.0]]},
                            surface={"generator": "midpoint", "levels": 4, "spacing": 1e-4, "rms_height": 1e-5,
                                     "fractal_dimension": 2.3, "seed": 1}))
    for task in study.tasks():
        groups = task_groups(solve_task(task, MPI.COMM_SELF))
        held, read = held_groups(groups), read_groups(encode(groups), fields=False)
        assert list(held) == list(read) and len(held) == (3 if task.index == 0 else 1)
        for name, (variables, attrs) in read.items():
            mine, my_attrs = held[name]
            assert list(mine) == list(variables) and my_attrs.keys() == attrs.keys()
            assert all(np.array_equal(my_attrs[k], attrs[k]) for k in attrs), name
            for key, var in variables.items():
                ours = mine[key]
                assert (ours.dims, ours.is_coord, ours.attrs.keys()) == (var.dims, var.is_coord, var.attrs.keys()), key
                assert all(np.array_equal(ours.attrs[k], var.attrs[k]) for k in var.attrs), key
                if isinstance(var.values, Unread):
                    assert ours.values == var.values, key
                else:
                    assert (ours.values.dtype, ours.values.shape) == (var.values.dtype, var.values.shape), key
                    assert np.array_equal(ours.values, var.values, equal_nan=var.values.dtype.kind == "f"), key


def test_task_file_larger_than_the_study_is_refused_by_name(tmp_path):
    """A task file with more loads than the study (not one of its tasks) is an error naming the
    file, not a silently dropped set of fields."""
    from roughcontact.farm.combine import combine
    from roughcontact.farm.records import encode

    def study(loads):
        return load_study(tiny(name="misfit", tangential={}, axes={"seeds": 2}, normal={"loads": loads},
                               surface={"generator": "midpoint", "levels": 3, "spacing": 1e-4,
                                        "rms_height": 1e-5, "fractal_dimension": 2.3},
                               output={"fields": "none"}))

    small, large = study([2.0, 5.0]), study([2.0, 5.0, 10.0])
    paths = {0: tmp_path / "task-0.nc", 1: tmp_path / "task-1.nc"}
    encode(task_groups(solve_task(small.tasks()[0], MPI.COMM_SELF)), paths[0])
    encode(task_groups(solve_task(large.tasks()[1], MPI.COMM_SELF)), paths[1])
    with pytest.raises(InputError, match="normal_load.*not a file of this study") as info:
        combine(small, paths)
    assert info.value.parameter == str(paths[1])


def test_ensemble_statistics_are_student_t_intervals_over_seeds():
    """Mean, sample standard deviation and the 95 % Student-t interval of the mean over seeds,
    against numpy and scipy.stats.t.interval on each column (to 1e-12: the same formulas
    evaluated differently); NaN (a failed task) leaves its sample out; fields and the task status
    (a CF flag) are not averaged."""
    from scipy import stats

    from roughcontact.analysis import ensemble_statistics
    from roughcontact.farm.records import STATUS_ATTRS

    rng = np.random.default_rng(3)
    values = rng.normal(0.1, 0.02, size=(3, 6, 4))
    values[1, 2, 3] = np.nan
    ds = xr.Dataset({"contact_fraction": (("fractal_dimension", "seed", "normal_load"), values, {"units": "1"}),
                     "status": (("fractal_dimension", "seed"), np.zeros((3, 6), np.int8), STATUS_ATTRS),
                     "contact": (("seed", "x", "y"), np.zeros((6, 2, 2), np.int8))},
                    coords={"fractal_dimension": [2.1, 2.3, 2.5], "seed": np.arange(1, 7),
                            "normal_load": [1.0, 2.0, 3.0, 4.0]})
    out = ensemble_statistics(ds)
    assert set(out.data_vars) == {"contact_fraction", "contact_fraction_std", "contact_fraction_lower",
                                  "contact_fraction_upper", "contact_fraction_samples"}
    assert out["contact_fraction"].attrs["units"] == "1" and "seed" not in out.dims
    for i in range(3):
        for j in range(4):
            sample = values[i, :, j][np.isfinite(values[i, :, j])]
            low, high = stats.t.interval(0.95, sample.size - 1, loc=sample.mean(),
                                         scale=sample.std(ddof=1) / np.sqrt(sample.size))
            got = [float(out[f"contact_fraction{suffix}"][i, j]) for suffix in ("", "_std", "_lower", "_upper",
                                                                                "_samples")]
            np.testing.assert_allclose(got, [sample.mean(), sample.std(ddof=1), low, high, sample.size],
                                       rtol=1e-12)
    with pytest.raises(InputError) as info:
        ensemble_statistics(ds, "realisation")
    assert info.value.parameter == "dim"


def test_a_batch_log_gets_a_progress_line_every_interval():
    """stderr not a terminal (a Slurm log): a whole line every interval, counting what finished,
    and none after close; a terminal-less --quiet run writes nothing."""
    import io
    import time

    from roughcontact.farm.progress import Progress

    log = io.StringIO()
    progress = Progress("batch", total=10, resumed=2, stream=log, interval=0.02)
    progress.task_done(False, 100)
    progress.task_done(True, 100)
    deadline = time.monotonic() + 30
    while log.getvalue().count("\n") < 2 and time.monotonic() < deadline:
        time.sleep(0.005)
    progress.close()
    lines = log.getvalue().splitlines()
    assert len(lines) >= 2 and all(line.startswith("batch: 4/10 tasks, 1 failed") for line in lines)
    assert not progress._ticker.is_alive()          # close joined it: nothing more comes
    silent = io.StringIO()
    Progress("quiet", total=10, resumed=0, enabled=False, stream=silent, interval=0.01).close()
    assert silent.getvalue() == ""


@pytest.mark.parametrize("fields", ["none", "contact", "force"])
def test_a_task_keeps_only_the_fields_it_stores_and_writes_the_same_numbers(fields):
    """Each load's whole result serves its tangential sweep, fretting cycle and energy first, then
    only the fields stored at ``fields`` are kept (the others None): every variable of the task's
    file is the one the same task writes keeping every field, bit for bit (wall times aside)."""
    from roughcontact.datasets import FIELD_TABLE, stored_fields

    everything = load_study(tiny()).tasks()[1]
    kept = load_study(tiny(output={"fields": fields})).tasks()[1]
    whole, slim = solve_task(everything, MPI.COMM_SELF), solve_task(kept, MPI.COMM_SELF)
    assert whole.error is None and slim.error is None and len(slim.normal) == 3
    names = stored_fields(FIELD_TABLE, fields)
    for result, reference in zip(slim.normal, whole.normal):
        for name in FIELD_TABLE:
            if name in names:
                np.testing.assert_array_equal(getattr(result, name), getattr(reference, name))
            else:
                assert getattr(result, name) is None, name
    mine, theirs = task_groups(slim), task_groups(whole)
    assert mine.keys() == theirs.keys() == {"/", "tangential", "fretting"}
    for group, ds in mine.items():
        for var in ds.data_vars:
            if not timing(var):
                np.testing.assert_array_equal(ds[var].values, theirs[group][var].values, err_msg=f"{group}/{var}")
    assert set(FIELD_TABLE) - set(names) <= set(theirs["/"].data_vars) - set(mine["/"].data_vars)


def test_a_task_without_tangential_work_solves_on_rows(comm):
    """On a group of several ranks, a task with no tangential sweep or fretting solves its loads on
    the surface by rows: its first rank makes the surface and receives the fields the task stores;
    the other ranks hold neither. Each load is the solve of the whole surface on the same ranks, bit
    for bit (the same rows, the same sums)."""
    from roughcontact.farm.task import open_normal_solver

    if comm.Get_size() == 1:
        pytest.skip("needs a group of several ranks")
    task = load_study(tiny(name="rows", tangential={}, output={"fields": "force"})).tasks()[0]
    outcome = solve_task(task, comm)
    assert outcome.error is None and len(outcome.normal) == 3
    with open_normal_solver(task.topography(), task.interface, comm, task.normal) as solver:
        reference = [task.normal.solve(solver, task.load_dim, float(value)) for value in task.loads]
    first = comm.Get_rank() == 0
    assert (outcome.topography is not None) == first
    for got, expected in zip(outcome.normal, reference):
        for name in ("load", "closure", "rotation", "moments", "contact_area", "linear_iterations", "residual"):
            assert getattr(got, name) == getattr(expected, name), name
        assert got.pressure is None and got.gap is None and not got.distributed
        if first:
            np.testing.assert_array_equal(got.force, expected.force)
            np.testing.assert_array_equal(got.contact, expected.contact)
        else:
            assert got.force is None and got.contact is None


def test_a_surface_that_cannot_be_made_ends_the_task_on_every_rank(comm, monkeypatch):
    """On rows only the first rank makes the surface: its failure ends the task on every rank of the
    group with the same message and error name (no rank is left waiting for its rows)."""
    from roughcontact.farm.task import Task

    if comm.Get_size() == 1:
        pytest.skip("needs a group of several ranks")

    def broken(self):
        raise InputError("surface", "forced for the test")

    monkeypatch.setattr(Task, "topography", broken)
    outcome = solve_task(load_study(tiny(name="rows", tangential={})).tasks()[0], comm)
    assert outcome.error == "InputError: surface: forced for the test" and outcome.normal == []
    assert comm.allgather(outcome.error) == [outcome.error] * comm.Get_size()
