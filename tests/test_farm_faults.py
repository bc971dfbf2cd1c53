"""Faults of a real ``mpiexec`` job: SIGKILL of the job or of one rank, and a rank that raises.

Each test launches ``mpiexec -n 2`` itself, so it runs in the serial pass
only. A small driver wraps :func:`roughcontact.farm.task.solve_task` (as the
farm calls it) to append ``<task> <pid> <rank>`` to a log after each solve
(and, when asked, to raise on one rank), then runs the command line: the
log counts the solves of every run, independently of what the run reports.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

DRIVER = '''
import os, sys
from mpi4py import MPI
import roughcontact.farm.run as farm_run

solve, log, fault = farm_run.solve_task, os.environ["RC_SOLVE_LOG"], os.environ.get("RC_FAULT")
done = []

def counted(task, comm):
    rank = MPI.COMM_WORLD.Get_rank()
    if fault and fault == f"{rank}:{len(done)}":     # "<rank>:<tasks it solves first>"
        raise RuntimeError(f"injected fault in task {task.index}")
    outcome = solve(task, comm)
    done.append(task.index)
    if comm.Get_rank() == 0:
        with open(log, "a") as stream:
            stream.write(f"{task.index} {os.getpid()} {rank}\\n")
    return outcome

farm_run.solve_task = counted
from roughcontact.cli import main
sys.exit(main())
'''

STUDY = '''
name = "faults"
[surface]
levels = 5
spacing = 1e-4
rms_height = 1e-5
[axes]
fractal_dimension = [2.1, 2.3, 2.5]
seeds = 8
[materials]
body1 = { E = 20e9, nu = 0.0 }
body2 = { E = 20e9, nu = 0.0 }
[normal]
loads = [50.0, 100.0, 200.0, 300.0, 400.0, 500.0]
[farm]
ranks_per_task = {k}
'''
TASKS = 24


@pytest.fixture
def job(tmp_path, comm):
    if comm.Get_size() > 1:
        pytest.skip("launches mpiexec itself; run by the serial pass")
    return Job(tmp_path)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The scalars of an uninterrupted run on the same layout (two groups of one rank)."""
    from mpi4py import MPI

    if MPI.COMM_WORLD.Get_size() > 1:
        pytest.skip("launches mpiexec itself; run by the serial pass")
    job = Job(tmp_path_factory.mktemp("reference"))
    run = job.run("reference", "reference.log")
    assert run.returncode == 0, run.stderr
    return scalars(job.root / "reference" / "faults.nc")


class Job:
    """``mpiexec -n 2`` runs of the fault study in one directory, and what they left behind."""

    def __init__(self, root: Path):
        self.root = root
        (root / "driver.py").write_text(DRIVER)
        self.write_study(1)

    def write_study(self, k: int) -> None:
        (self.root / "study.toml").write_text(STUDY.replace("{k}", str(k)))

    def command(self, output: str) -> list[str]:
        launcher = Path(sys.executable).parent / "mpiexec"
        return [str(launcher), "-n", "2", sys.executable, str(self.root / "driver.py"), "run",
                str(self.root / "study.toml"), "--output", str(self.root / output), "--quiet"]

    def env(self, log: str, fault: str | None = None) -> dict:
        env = {**os.environ, "RC_SOLVE_LOG": str(self.root / log), "OPENBLAS_NUM_THREADS": "1"}
        env.pop("RC_FAULT", None)
        if fault:
            env["RC_FAULT"] = fault
        return env

    def run(self, output: str, log: str, fault: str | None = None, timeout: float = 120):
        return subprocess.run(self.command(output), env=self.env(log, fault), capture_output=True, text=True,
                              timeout=timeout)

    def files(self, output: str) -> dict[int, bytes]:
        return {int(p.stem.split("-")[1]): p.read_bytes()
                for p in (self.root / output / "faults.tasks").glob("task-*.nc")}

    def solves(self, log: str) -> list[tuple[int, int, int]]:
        path = self.root / log
        return [tuple(map(int, line.split())) for line in path.read_text().splitlines()] if path.exists() else []

    def kill_after(self, output: str, log: str, files: int, victim) -> None:
        """Start a run and SIGKILL ``victim(process, solves)`` once ``files`` task files exist."""
        process = subprocess.Popen(self.command(output), env=self.env(log), start_new_session=True,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 120
        while len(self.files(output)) < files:
            assert process.poll() is None, "the run ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        victim(process, self.solves(log))
        try:
            process.wait(timeout=60)
        finally:
            if _alive_group(process.pid):
                os.killpg(process.pid, signal.SIGKILL)


def _alive_group(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False


def scalars(path: Path) -> xr.Dataset:
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.drop_vars([v for v in ds.data_vars if "elapsed" in v]).load()


def kill_job(process, solves):
    os.killpg(process.pid, signal.SIGKILL)


def kill_rank_1(process, solves):
    pid = next(pid for _, pid, rank in solves if rank == 1)
    os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("victim", [kill_job, kill_rank_1], ids=["whole job", "one rank"])
def test_resume_after_sigkill_recomputes_nothing_and_loses_nothing(job, reference, victim):
    """SIGKILL (of ``mpiexec`` and its ranks, or of rank 1 alone) once three tasks are on disk;
    the same command again solves exactly the tasks without a file, leaves the others' files
    untouched, and gives the scalars of an uninterrupted run bit for bit (same rank layout)."""
    job.kill_after("out", "first.log", files=3, victim=victim)
    survived = job.files("out")
    assert 3 <= len(survived) < TASKS
    assert set(survived) <= {task for task, _, _ in job.solves("first.log")}
    resumed = job.run("out", "second.log")
    assert resumed.returncode == 0, resumed.stderr
    again = {task for task, _, _ in job.solves("second.log")}
    assert again == set(range(TASKS)) - set(survived)                  # nothing finished is recomputed
    after = job.files("out")
    assert all(after[i] == data for i, data in survived.items())       # nor rewritten
    resumed_ds = scalars(job.root / "out" / "faults.nc")
    assert set(resumed_ds.data_vars) == set(reference.data_vars)
    for name in reference.data_vars:
        np.testing.assert_array_equal(resumed_ds[name].values, reference[name].values, err_msg=name)


@pytest.mark.parametrize("k", [1, 2])
def test_a_raising_rank_aborts_the_job_with_its_message(job, k):
    """An unexpected exception on rank 1 (a group leader with k = 1, a group member with k = 2)
    ends the whole job within the timeout, with the message and the rank, instead of leaving
    the other rank waiting; the next run resumes from the tasks already written."""
    import re

    job.write_study(k)
    started = time.monotonic()
    failed = job.run("out", "first.log", fault="1:3", timeout=90)    # rank 1's fourth task raises
    assert time.monotonic() - started < 90
    assert failed.returncode != 0
    faulty = re.search(r"injected fault in task (\d+)", failed.stderr)
    assert faulty and "rank 1 of 2" in failed.stderr, failed.stderr
    written = job.files("out")
    assert int(faulty.group(1)) not in written
    resumed = job.run("out", "second.log")
    assert resumed.returncode == 0, resumed.stderr
    assert {task for task, _, _ in job.solves("second.log")} == set(range(TASKS)) - set(written)


def test_more_ranks_than_cores_is_warned_about(tmp_path, comm):
    """One rank more than this machine's cores: the run says it is oversubscribed."""
    if comm.Get_size() > 1:
        pytest.skip("launches mpiexec itself; run by the serial pass")
    cores = len(os.sched_getaffinity(0))
    if cores > 4:
        pytest.skip(f"{cores + 1} ranks would be a heavy test here")
    check = ("from mpi4py import MPI; from roughcontact.farm.guards import oversubscription; "
             "m = oversubscription(MPI.COMM_WORLD); print(m if MPI.COMM_WORLD.rank == 0 else '', flush=True)")
    run = subprocess.run([str(Path(sys.executable).parent / "mpiexec"), "-n", str(cores + 1), sys.executable,
                          "-c", check], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert f"{cores + 1} ranks share {cores} core(s)" in run.stdout and "oversubscribed" in run.stdout
