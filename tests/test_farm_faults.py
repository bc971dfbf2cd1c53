"""Faults of a real ``mpiexec`` job: SIGKILL of the job or of one rank, a rank that raises, a full disk.

Each test launches ``mpiexec -n 2`` itself, so it runs in the serial pass
only. The jobs are those of the fault campaign (:mod:`benchmarks.bench_faults`):
a small driver wraps :func:`roughcontact.farm.task.solve_task` (as the farm
calls it) to append ``<task> <pid> <rank>`` to a log after each solve (and,
when asked, to raise on one rank or to fail a task-file write with ENOSPC),
then runs the command line: the log counts the solves of every run,
independently of what the run reports.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from benchmarks.bench_faults import KINDS, TASKS, Job, campaign, kill_run, scalars


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


def kill_job(process, solves, output):
    kill_run(output, process)


def kill_rank_1(process, solves, output):
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
    record = json.loads((job.root / "out" / "faults.failure.json").read_text())     # the reason, on disk
    assert record["rank"] == 1 and record["exit_status"] == 70 and "injected fault" in record["message"]
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


@pytest.mark.parametrize("rank", [0, 1])
def test_a_full_disk_ends_the_job_with_one_line_and_the_same_command_resumes(job, reference, rank):
    """ENOSPC on the third task file a leader writes (rank 0, or rank 1 beside it): the job ends
    with status 74 and one line on stderr naming the file, the count of task files safely on
    disk and the resume hint (no traceback); no combined file; the reason in the failure record.
    Space freed, the same command solves exactly the tasks without a file and gives the scalars
    of an uninterrupted run bit for bit."""
    failed = job.run("out", "first.log", full=f"{rank}:2", timeout=90)
    assert failed.returncode == 74, failed.stderr
    lines = [line for line in failed.stderr.splitlines() if line.startswith("roughcontact:")]
    assert len(lines) == 1 and "Traceback" not in failed.stderr, failed.stderr
    written = job.files("out")
    assert "No space left on device" in lines[0] and "faults.tasks/task-" in lines[0]
    assert "task file(s) are safely on disk" in lines[0] and "run the same command again" in lines[0]
    on_disk = int(lines[0].split(" task file(s) are safely")[0].rsplit(" ", 1)[1])
    assert on_disk <= len(written) < TASKS
    assert not (job.root / "out" / "faults.nc").exists()
    record = json.loads((job.root / "out" / "faults.failure.json").read_text())
    assert record["exit_status"] == 74 and record["rank"] == rank and "No space left" in record["message"]
    resumed = job.run("out", "second.log")
    assert resumed.returncode == 0, resumed.stderr
    assert {task for task, _, _ in job.solves("second.log")} == set(range(TASKS)) - set(written)
    assert not (job.root / "out" / "faults.failure.json").exists()
    resumed_ds = scalars(job.root / "out" / "faults.nc")
    for name in reference.data_vars:
        np.testing.assert_array_equal(resumed_ds[name].values, reference[name].values, err_msg=name)


@pytest.mark.slow
def test_a_full_disk_on_rank_0_ends_with_its_one_line_every_time(job):
    """ENOSPC in rank 0's own task file while its manager thread serves rank 1's leader: MPICH's
    MPI_Abort returned to the caller 3 times in 40 such runs, which then went on with the result it
    never got and printed a traceback (once with exit 70). 60 runs (the chance that 60 runs all pass
    at the old rate of 3 in 40 is 1 %): every one exits 74 with one line on stderr and no traceback."""
    for run in range(60):
        failed = job.run(f"out{run}", f"log{run}", full="0:2", timeout=90)
        lines = [line for line in failed.stderr.splitlines() if line.startswith("roughcontact:")]
        assert failed.returncode == 74 and len(lines) == 1 and "Traceback" not in failed.stderr, \
            (run, failed.returncode, failed.stderr)


def test_one_fault_of_each_kind_at_a_random_moment_loses_and_recomputes_nothing(job):
    """The campaign's fast subset: one run of each fault kind (SIGKILL of the job, of rank 1, a
    raising task, ENOSPC at a random write, a truncated task file), each at a moment drawn from a
    fixed seed, each followed by the same command: no task lost, none recomputed beyond those in
    flight (and the one truncated), no hang, and the dataset of an uninterrupted run to 1e-12."""
    report = campaign(job.root, runs=1, seed=11, hang=90.0, log=lambda *a: None)
    assert set(report["table"]) == set(KINDS)
    for kind, row in report["table"].items():
        assert (row["runs"], row["tasks_lost"], row["recomputed_beyond_in_flight"], row["hangs"]) == (1, 0, 0, 0), \
            (kind, report["rows"])
        assert row["equal_to_uninterrupted"] == 1 and row["resumes_exit_0"] == 1, (kind, report["rows"])
        assert row["one_line_on_stderr"] == 1, (kind, report["rows"])


def test_two_jobs_on_one_output_split_the_work_without_solving_a_task_twice(job, reference):
    """A resubmission while the first job still runs: both on one --output, started together.
    Lease files give each task to one job: every task is solved exactly once over the two, both
    exit 0, and the dataset is the uninterrupted run's bit for bit (same one-rank groups)."""
    first = job.start("out", "a.log", None, capture=True)
    second = job.start("out", "b.log", None, capture=True)
    outs = [p.communicate(timeout=240) for p in (first, second)]
    assert (first.returncode, second.returncode) == (0, 0), outs
    solved = [task for log in ("a.log", "b.log") for task, _, _ in job.solves(log)]
    assert sorted(solved) == list(range(TASKS))                      # each exactly once
    assert job.solves("a.log") and job.solves("b.log")                # both did work
    assert not list((job.root / "out" / "faults.tasks").glob("*.lease"))
    combined = scalars(job.root / "out" / "faults.nc")
    for name in reference.data_vars:
        np.testing.assert_array_equal(combined[name].values, reference[name].values, err_msg=name)


def test_a_two_shard_array_solves_each_task_once_and_the_last_shard_combines(job, reference):
    """--shard 0/2 then --shard 1/2 (as a Slurm array's two jobs): the first solves its part and
    does not combine (exit 0, "not combined"); the second solves the rest and writes the dataset of
    an uninterrupted run, bit for bit."""
    part = subprocess.run(job.command("out", "--shard", "0/2"), env=job.env("a.log"), capture_output=True,
                          text=True, timeout=120)
    assert part.returncode == 0 and "not combined" in part.stdout, part.stdout + part.stderr
    assert not (job.root / "out" / "faults.nc").exists()
    env = {**job.env("b.log"), "SLURM_ARRAY_TASK_ID": "8", "SLURM_ARRAY_TASK_MIN": "7", "SLURM_ARRAY_TASK_COUNT": "2"}
    rest = subprocess.run(job.command("out"), env=env, capture_output=True, text=True, timeout=120)
    assert rest.returncode == 0, rest.stderr
    a, b = ({task for task, _, _ in job.solves(log)} for log in ("a.log", "b.log"))
    assert a and b and not a & b and a | b == set(range(TASKS))
    combined = scalars(job.root / "out" / "faults.nc")
    for name in reference.data_vars:
        np.testing.assert_array_equal(combined[name].values, reference[name].values, err_msg=name)


def test_sigterm_drains_the_run_and_the_same_command_resumes(job, reference):
    """SIGTERM to mpiexec (forwarded to the ranks, as Slurm does before the wall-time limit) once
    three tasks are on disk: no new task starts, those in flight are written whole, the job exits
    75 with the resume hint and no combined file; the same command solves exactly the rest."""
    process = job.start("out", "first.log", None, capture=True)
    deadline = time.monotonic() + 120
    while len(job.files("out")) < 3:
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.01)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 75, err
    assert "SIGTERM: draining" in err and "run the same command again" in out
    assert not (job.root / "out" / "faults.nc").exists()
    written = job.files("out")
    assert {task for task, _, _ in job.solves("first.log")} == set(written) and len(written) < TASKS
    resumed = job.run("out", "second.log")
    assert resumed.returncode == 0, resumed.stderr
    assert {task for task, _, _ in job.solves("second.log")} == set(range(TASKS)) - set(written)
    combined = scalars(job.root / "out" / "faults.nc")
    for name in reference.data_vars:
        np.testing.assert_array_equal(combined[name].values, reference[name].values, err_msg=name)


def test_two_groups_of_two_ranks_beside_each_other(job, reference):
    """4 ranks (oversubscribed here: correctness, not speed) in two groups of k = 2: each task's
    operator distributed over its group; the scalars equal the one-rank-per-task run's to 1e-6
    relative (the same solves, sums in another order, each converged to tol 1e-8). The moments are
    zero to that tolerance (θ is found from them): they are compared to 1e-8 P_max L. Iteration
    counts and residuals, which rounding moves, are not compared."""
    job.write_study(2)
    run = subprocess.run(job.command("out", ranks=4), env=job.env("a.log"), capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    assert len({rank for _, _, rank in job.solves("a.log")}) == 2          # both groups' leaders solved
    combined = scalars(job.root / "out" / "faults.nc")
    for name in reference.data_vars:
        if "iterations" in name or "residual" in name:     # solver diagnostics: rounding moves them
            continue
        a, b = reference[name].values, combined[name].values
        if a.dtype.kind == "f":
            scale = 500.0 * 32 * 1e-4 if name.startswith("moment") else np.nanmax(np.abs(a))
            np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-8 * scale, err_msg=name)
        else:
            np.testing.assert_array_equal(b, a, err_msg=name)


def test_rank_0_that_does_not_work_only_hands_out_and_the_dataset_is_unchanged(job, reference):
    """4 ranks (oversubscribed here) with ``[farm] root_works = false``: rank 0 solves no task, the
    three other ranks solve them all, and the dataset is the two-rank run's bit for bit (the same
    one-rank solves, only placed by another rank)."""
    job.write_study(1, root_works=False)
    run = subprocess.run(job.command("out", ranks=4), env=job.env("a.log"), capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    solves = job.solves("a.log")
    assert sorted(task for task, _, _ in solves) == list(range(TASKS))
    assert {rank for _, _, rank in solves} == {1, 2, 3}
    combined = scalars(job.root / "out" / "faults.nc")
    for name in reference.data_vars:
        np.testing.assert_array_equal(combined[name].values, reference[name].values, err_msg=name)
