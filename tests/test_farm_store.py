"""The study store meets grown ensembles, damaged task files and failed writes.

Run serially and under ``mpiexec -n 2`` (in-process runs on the suite's
communicator). Faults that end a multi-rank job (a write that fails on a
group leader) are in tests/test_farm_faults.py, which launches its own jobs.
Expected values are those of an uninterrupted run of the same study on the
same layout: with one rank per task the arithmetic is the same, so equality
is bitwise.
"""
from __future__ import annotations

import errno
import json

import numpy as np
import pytest
import xarray as xr

from roughcontact.errors import InputError, StorageError
from roughcontact.farm import load_study, run_study
from roughcontact.farm.store import TaskStore, check_task_file


def study(name: str, seeds: int = 2, dimensions=(2.2,), **tables) -> dict:
    """Δ × seeds on 9² nodes, two loads: small enough that a run is a fraction of a second."""
    raw = {"name": name,
           "surface": {"generator": "midpoint", "levels": 3, "spacing": 1e-4, "rms_height": 1e-5},
           "axes": {"fractal_dimension": list(dimensions), "seeds": seeds},
           "materials": {"body1": {"E": 20e9, "nu": 0.0}, "body2": {"E": 20e9, "nu": 0.0}},
           "normal": {"loads": [2.0, 5.0]},
           "output": {"fields": "contact"}}
    raw.update(tables)
    return raw


#: study("combined", seeds=3) as a study file
COMBINED = """
name = "combined"
[surface]
generator = "midpoint"
levels = 3
spacing = 1e-4
rms_height = 1e-5
[axes]
fractal_dimension = [2.2]
seeds = 3
[materials]
body1 = { E = 20e9, nu = 0.0 }
body2 = { E = 20e9, nu = 0.0 }
[normal]
loads = [2.0, 5.0]
[output]
fields = "contact"
"""


def quiet(*args, **kwargs):
    pass


def dataset(path) -> xr.Dataset:
    """The combined root group without wall times (they differ from run to run)."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.drop_vars([v for v in ds.data_vars if "elapsed" in v]).load()


def assert_same(a: xr.Dataset, b: xr.Dataset) -> None:
    assert set(a.data_vars) == set(b.data_vars) and dict(a.sizes) == dict(b.sizes)
    for name in a.variables:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


def mtimes(store: TaskStore, tasks) -> dict:
    return {t.key: store.path(t).stat().st_mtime_ns for t in tasks}


def test_a_grown_and_reordered_ensemble_keeps_every_finished_task(comm, shared_dir):
    """seeds 2 → 3 and Δ [2.2] → [2.4, 2.2]: the two finished tasks are kept (not rewritten), only
    the four new ones are solved, and the combined dataset equals a fresh run's of the grown study."""
    first = load_study(study("grown"))
    run_study(first, comm, shared_dir / "a", log=quiet, quiet=True)
    store = TaskStore(shared_dir / "a", "grown")
    kept = mtimes(store, first.tasks())
    grown = load_study(study("grown", seeds=3, dimensions=(2.4, 2.2)))
    summary = run_study(grown, comm, shared_dir / "a", log=quiet, quiet=True)
    assert (summary.resumed, summary.solved, summary.exit_code) == (2, 4, 0)
    assert mtimes(store, first.tasks()) == kept
    # each file names the study (and the definition) that wrote it, its task and the code version
    import h5py

    from roughcontact import __version__

    for task in grown.tasks():
        with h5py.File(store.path(task), "r") as f:
            writer = first if task.key in kept else grown
            assert (f.attrs["study"], f.attrs["study_sha256"]) == ("grown", writer.identity)
            assert (f.attrs["task_key"], f.attrs["roughcontact_version"]) == (task.key, __version__)
    assert first.identity != grown.identity
    fresh = run_study(grown, comm, shared_dir / "b", log=quiet, quiet=True)
    assert fresh.solved == 6
    assert_same(dataset(summary.paths["netcdf"]), dataset(fresh.paths["netcdf"]))
    # shrinking back keeps the files of the values left out, unused
    again = run_study(first, comm, shared_dir / "a", log=quiet, quiet=True)
    assert (again.resumed, again.solved) == (2, 0) and store.on_disk() == 6


@pytest.mark.parametrize("change, key", [
    ({"surface": {"generator": "midpoint", "levels": 3, "spacing": 1e-4, "rms_height": 2e-5}}, "surface.rms_height"),
    ({"materials": {"body1": {"E": 30e9, "nu": 0.0}, "body2": {"E": 20e9, "nu": 0.0}}}, "materials.body1.E"),
    ({"normal": {"loads": [2.0, 5.0], "method": "cg"}}, "normal.method"),
    ({"output": {"fields": "none"}}, "output.fields"),
])
def test_a_change_of_what_a_task_means_is_refused_naming_the_key(comm, shared_dir, change, key):
    """A resume may change the axes only; any other change of the results refuses, naming the key."""
    run_study(load_study(study("changed")), comm, shared_dir, log=quiet, quiet=True)
    with pytest.raises(InputError, match=f"other values of {key}") as info:
        run_study(load_study(study("changed", **change)), comm, shared_dir, log=quiet, quiet=True)
    assert info.value.parameter == key


def test_damaged_task_files_are_moved_aside_and_solved_again(comm, shared_dir):
    """A truncated file (a copy cut short by a full quota), a file of another task copied over
    one, and bytes that are not HDF5: each is moved aside to ``<file>.damaged`` with a warning, its
    task alone is solved again, and the dataset equals the undamaged run's."""
    definition = load_study(study("damaged", seeds=4))
    tasks = definition.tasks()
    before = run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    reference = dataset(before.paths["netcdf"])
    store = TaskStore(shared_dir, "damaged")
    comm.Barrier()
    if comm.Get_rank() == 0:
        whole = store.path(tasks[0]).read_bytes()
        store.path(tasks[0]).write_bytes(whole[: len(whole) // 2])
        store.path(tasks[1]).write_bytes(store.path(tasks[2]).read_bytes())
        store.path(tasks[3]).write_bytes(b"not an HDF5 file")
    comm.Barrier()
    for index in (0, 1, 3):
        with pytest.raises(ValueError):
            check_task_file(store.path(tasks[index]), tasks[index])
    kept = store.path(tasks[2]).stat().st_mtime_ns
    after = run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    assert (after.resumed, after.solved, after.exit_code) == (1, 3, 0)
    assert store.path(tasks[2]).stat().st_mtime_ns == kept
    aside = sorted(p.name for p in store.directory.glob("*.damaged"))
    assert aside == sorted(store.path(tasks[i]).name + ".damaged" for i in (0, 1, 3))
    assert_same(dataset(after.paths["netcdf"]), reference)


def test_a_file_damaged_before_the_combine_leaves_its_task_without_a_result(tmp_path):
    """combine never dies on one file: a task whose file HDF5 cannot read is handed to the
    callback and left NaN with status −1; the others are placed as before."""
    from mpi4py import MPI

    from roughcontact.farm.combine import combine

    definition = load_study(study("combine", seeds=3))
    summary = run_study(definition, MPI.COMM_SELF, tmp_path, log=quiet, quiet=True)
    reference = dataset(summary.paths["netcdf"])
    store = TaskStore(tmp_path, "combine")
    tasks = definition.tasks()
    whole = store.path(tasks[1]).read_bytes()
    store.path(tasks[1]).write_bytes(whole[:1000])
    handed = []
    root = combine(definition, {t.index: store.path(t) for t in tasks},
                   lambda task, path, why: handed.append((task.index, path))).load()["/"]
    assert handed == [(1, store.path(tasks[1]))]
    assert root["status"].values.tolist() == [[0, -1, 0]]
    assert root["closure"].isel(seed=1).isnull().all()
    for seed in (0, 2):
        np.testing.assert_array_equal(root["closure"].isel(seed=seed), reference["closure"].isel(seed=seed))
    with pytest.raises(InputError, match="HDF5 cannot read") as info:
        combine(definition, {t.index: store.path(t) for t in tasks})
    assert info.value.parameter == str(store.path(tasks[1]))


def test_a_full_disk_at_the_combine_leaves_no_half_written_file_and_resumes(comm, shared_dir, monkeypatch):
    """ENOSPC while writing the combined dataset: a StorageError (one line: what, the path, the
    task files on disk, the resume hint) on every rank, no ``.nc`` nor ``.part`` left, the reason
    in the failure record; the same run again solves nothing and writes the dataset."""
    import roughcontact.farm.combine as combine_module

    definition = load_study(study("full-disk"))
    encode = combine_module.encode

    def full(groups, target=None, **layout):
        with open(target, "wb") as stream:
            stream.write(b"\0" * 100)          # a partly written file, as a real full disk leaves
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(combine_module, "encode", full)
    with pytest.raises(StorageError) as info:
        run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    message = str(info.value)
    store = TaskStore(shared_dir, "full-disk")
    comm.Barrier()                          # rank 0 has written the failure record
    assert "\n" not in message and str(store.combined) in message and "No space left on device" in message
    assert "2 task file(s) are safely on disk" in message and "run the same command again" in message
    assert not store.combined.exists() and not list(shared_dir.glob("*.part"))
    record = json.loads(store.failure.read_text())
    assert record["exit_status"] == 74 and "No space left" in record["message"]
    monkeypatch.setattr(combine_module, "encode", encode)
    comm.Barrier()
    again = run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    assert (again.solved, again.resumed, again.exit_code) == (0, 2, 0) and store.combined.exists()
    assert not store.failure.exists()


def test_a_store_of_the_earlier_layout_is_renamed_to_keys(comm, shared_dir):
    """Task files named by position (``task-00001.nc``, the earlier layout) under a manifest of
    the same definition are renamed to their keys and kept, not solved again."""
    definition = load_study(study("layout", seeds=3))
    run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    store = TaskStore(shared_dir, "layout")
    comm.Barrier()
    if comm.Get_rank() == 0:
        manifest = store.directory / "study.json"
        record = json.loads(manifest.read_text())
        manifest.write_text(json.dumps({"identity": record["identity"], "definition": record["definition"]}))
        for task in definition.tasks():
            store.path(task).rename(store.directory / f"task-{task.index:05d}.nc")
    comm.Barrier()
    again = run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    assert (again.resumed, again.solved) == (3, 0)
    assert all(store.path(t).exists() for t in definition.tasks())


def test_combine_command_solves_nothing_and_marks_tasks_without_a_file(comm, shared_dir, tmp_path_factory):
    """``roughcontact combine`` (no farm): with one task file removed it writes the dataset with
    that task's status −1 and exits 1; with every file present it exits 0 and writes what the run
    wrote, bit for bit (wall times aside)."""
    from roughcontact.cli import main

    path = shared_dir / "combined.toml"
    if comm.Get_rank() == 0:
        path.write_text(COMBINED)
    comm.Barrier()
    definition = load_study(path)
    assert definition.shared == load_study(study("combined", seeds=3)).shared
    summary = run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    reference = dataset(summary.paths["netcdf"])
    store = TaskStore(shared_dir, "combined")
    assert main(["combine", str(path), "--output", str(shared_dir)]) == 0
    assert_same(dataset(store.combined), reference)
    comm.Barrier()
    if comm.Get_rank() == 0:
        store.path(definition.tasks()[1]).unlink()
    comm.Barrier()
    assert main(["combine", str(path), "--output", str(shared_dir)]) == 1
    partial = dataset(store.combined)
    assert partial["status"].values.tolist() == [[0, -1, 0]]
    assert partial["closure"].isel(seed=1).isnull().all()


def test_the_combined_fields_are_each_task_files_fields_streamed_into_place(comm, shared_dir):
    """The combined dataset's fields are written task by task from the task files (never the
    study's whole fields in memory): for mated shifts (lenses of different extents in one
    frame), each task's fields equal its own file's at its offset, the rest is NaN (−1 for
    the int8 contact set), and the streamed file equals the same dataset built in memory.
    Equality is exact: values are copied, not computed."""
    from roughcontact.farm.combine import combine

    raw = study("streamed", seeds=1, output={"fields": "all"},
                axes={"mate_shift": [[0.0, 3e-4], [-4e-4, 0.0], [5e-4, 2e-4]]})
    raw["surface"].update(levels=4, fractal_dimension=2.3, seed=3, footprint_diameter=1.2e-3)
    definition = load_study(raw)
    summary = run_study(definition, comm, shared_dir, log=quiet, quiet=True)
    store = TaskStore(shared_dir, "streamed")
    combined = dataset(summary.paths["netcdf"])
    assert "differ in extent" in combined.attrs["fields_note"]
    s = float(combined["grid_spacing"].values.flat[0])
    for task in definition.tasks():
        own = dataset(store.path(task))
        mine = combined.isel(shift=task.position[0])
        i0 = int(round((float(own["origin_x"]) - float(combined["x"][0])) / s))
        j0 = int(round((float(own["origin_y"]) - float(combined["y"][0])) / s))
        inside = {"x": slice(i0, i0 + own.sizes["x"]), "y": slice(j0, j0 + own.sizes["y"])}
        for name in ("pressure", "gap", "contact"):
            np.testing.assert_array_equal(mine[name].isel(inside).values, own[name].values)
            outside = mine[name].values.copy()
            outside[:, inside["x"], inside["y"]] = own[name].values * 0 + (-1 if name == "contact" else np.nan)
            assert (outside == -1).all() if name == "contact" else np.isnan(outside).all()
    if comm.Get_rank() == 0:
        loaded = combine(definition, {t.index: store.path(t) for t in definition.tasks()}).load()["/"]
        loaded = loaded.drop_vars([v for v in loaded.data_vars if "elapsed" in v])
        xr.testing.assert_equal(loaded.drop_attrs(), combined.drop_attrs())


def test_a_lease_whose_pid_was_reused_is_stale_and_a_live_jobs_is_not(tmp_path):
    """A lease names (host, pid, start time) of its job's rank 0. A dead job's pid taken by a live
    process (here this process, under another start time) must not keep the lease: with the pid
    alone a resumed run waited on it for ever. The lease of a live job (this process as it is), and
    one of the earlier (host, pid) form whose pid is alive, are left alone."""
    import os
    import socket
    from types import SimpleNamespace

    from roughcontact.farm.leases import Leases, start_time

    started = start_time(os.getpid())
    if started == "-":
        pytest.skip("/proc gives no start times here")
    task = SimpleNamespace(key="abc")
    leases = Leases(lambda t: tmp_path / f"task-{t.key}.nc")
    lease = tmp_path / "task-abc.lease"
    host = socket.gethostname()
    try:
        lease.write_text(f"{host} {os.getpid()} {int(started) + 1}")       # the pid, reused since
        assert leases.claim(task) is True
        assert lease.read_text() == leases.owner
        leases.release(task)
        for owner in (f"{host} {os.getpid()} {started}", f"{host} {os.getpid()}"):
            lease.write_text(owner)
            assert leases.claim(task) is None
    finally:
        leases.close()


def test_an_empty_lease_is_stale_after_seconds_not_after_the_heartbeats_limit(tmp_path):
    """A job aborted between creating a lease and writing its owner (a full disk on rank 0 while
    its feeding thread claimed the next task) leaves it empty. With the age rule alone a resumed
    run waited STALE_SECONDS (120 s) on it, past the fault test's limit. A live job writes the
    owner within microseconds: an empty lease younger than EMPTY_SECONDS is left alone, an older
    one is taken over (and then names this job)."""
    import os
    import time
    from types import SimpleNamespace

    from roughcontact.farm.leases import EMPTY_SECONDS, STALE_SECONDS, Leases

    assert EMPTY_SECONDS < STALE_SECONDS
    task = SimpleNamespace(key="abc")
    leases = Leases(lambda t: tmp_path / f"task-{t.key}.nc")
    lease = tmp_path / "task-abc.lease"
    try:
        lease.write_text("")
        assert leases.claim(task) is None                                  # being written, maybe
        old = time.time() - EMPTY_SECONDS - 1.0
        os.utime(lease, (old, old))
        assert leases.claim(task) is True
        assert lease.read_text() == leases.owner
    finally:
        leases.close()


def test_a_lease_of_an_exited_process_not_yet_reaped_is_stale(tmp_path):
    """A job's rank 0 that has exited but is not yet reaped (a zombie) keeps its pid and start
    time in /proc, and signal 0 still reaches it: by those alone its leases stayed alive, and a
    resumed run waited on them for as long as the zombie lasted (for ever where an orphan's reaper
    does not reap). Its state, Z, says it has exited."""
    import os
    import socket
    import subprocess
    import sys
    import time
    from types import SimpleNamespace

    from roughcontact.farm.leases import Leases, _stat, start_time

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        deadline = time.monotonic() + 30.0
        while True:                       # /proc, not poll(): poll() would reap the child
            fields = _stat(child.pid)
            if fields is None:
                pytest.skip("/proc gives no process states here")
            state = fields[0]
            if state == "Z" or time.monotonic() > deadline:
                break
            time.sleep(0.01)
        assert state == "Z"
        started = start_time(child.pid)
        os.kill(child.pid, 0)             # still there for signal 0
        task = SimpleNamespace(key="abc")
        leases = Leases(lambda t: tmp_path / f"task-{t.key}.nc")
        lease = tmp_path / "task-abc.lease"
        try:
            lease.write_text(f"{socket.gethostname()} {child.pid} {started}")
            assert leases.claim(task) is True
            assert lease.read_text() == leases.owner
        finally:
            leases.close()
    finally:
        child.wait()
