#!/usr/bin/env python
"""The fault campaign: real ``mpiexec -n 2`` jobs of a 24-task study, each hit by one fault at a
random moment and then resumed by the same command.

Fault kinds (``--runs`` of each, default 6: 30 runs):

- ``kill-job``: SIGKILL of ``mpiexec`` and every rank at a random moment of the run (each rank
  by its pid: MPICH's proxy starts ranks in sessions of their own, so a signal to mpiexec's
  process group alone left them running, writing task files after the "kill" — no scheduler
  does that, and the suite's resume test failed on it once);
- ``kill-rank``: SIGKILL of rank 1 alone at a random moment;
- ``raise``: an unexpected exception in a random rank's n-th task (a defect, not a solver failure);
- ``enospc``: ENOSPC ("No space left on device") at a random task-file write of a random rank;
- ``truncate``: SIGKILL of the job at a random moment, then a random finished task file cut
  to a random length (a copy interrupted by a full quota).

Each run is counted independently of what the runs report: a small driver wraps
the farm's ``solve_task`` to log ``<task> <pid> <rank>`` after each solve, and
the task files on disk are read (bytes and the ``task`` attribute) after the
fault and after the resume. Per kind:

- tasks lost: files whole after the fault that the resume removed or changed, plus tasks
  without a completed result in the final dataset (must be 0);
- tasks recomputed beyond those in flight: tasks the resume solved that had a whole file
  after the fault, the file cut by ``truncate`` excepted (must be 0);
- hangs: a run or a resume still alive after ``--hang`` seconds (must be 0);
- equal: the final dataset's scalars equal an uninterrupted run's to 1e-12 (relative to each
  variable's largest magnitude; the same rank layout makes them equal bit for bit).

    python -m benchmarks.bench_faults                 # writes results/bench_faults.json
    python -m benchmarks.bench_faults --runs 1        # one of each kind (what the suite runs)

The classes here (:class:`Job`, the driver) are also what tests/test_farm_faults.py uses.
"""
from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DRIVER = '''
import os, sys
from mpi4py import MPI
import roughcontact.farm.run as farm_run

rank = MPI.COMM_WORLD.Get_rank()
if os.environ.get("RC_PIDS"):                          # each rank's pid, for a fault aimed at one rank
    with open(os.path.join(os.environ["RC_PIDS"], f"rank-{rank}"), "w") as stream:
        stream.write(str(os.getpid()))
solve, log, fault = farm_run.solve_task, os.environ["RC_SOLVE_LOG"], os.environ.get("RC_FAULT")
done = []

def counted(task, comm, **options):
    if fault and fault == f"{rank}:{len(done)}":     # "<rank>:<tasks it solves first>"
        raise RuntimeError(f"injected fault in task {task.index}")
    outcome = solve(task, comm, **options)
    done.append(task.index)
    if comm.Get_rank() == 0:
        with open(log, "a") as stream:
            stream.write(f"{task.index} {os.getpid()} {rank}\\n")
    return outcome

farm_run.solve_task = counted

full = os.environ.get("RC_ENOSPC")                     # "<rank>:<task files it writes first>"
if full:
    import errno
    import roughcontact.farm.store as store
    write, written = store._write_file, []

    def filling(path, payload):
        if path.name.startswith("task-"):
            if f"{rank}:{len(written)}" == full:
                raise OSError(errno.ENOSPC, "No space left on device", str(path))
            written.append(path)
        write(path, payload)

    store._write_file = filling
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
root_works = {root_works}
'''
TASKS = 24
KINDS = ("kill-job", "kill-rank", "raise", "enospc", "truncate")


class Job:
    """``mpiexec -n 2`` runs of the fault study in one directory, and what they left behind."""

    def __init__(self, root: Path):
        self.root = Path(root)
        (self.root / "driver.py").write_text(DRIVER)
        self.write_study(1)

    def write_study(self, k: int, root_works: bool = True) -> None:
        text = STUDY.replace("{k}", str(k)).replace("{root_works}", str(root_works).lower())
        (self.root / "study.toml").write_text(text)

    def command(self, output: str, *extra: str, ranks: int = 2) -> list[str]:
        launcher = Path(sys.executable).parent / "mpiexec"
        return [str(launcher), "-n", str(ranks), sys.executable, str(self.root / "driver.py"), "run",
                str(self.root / "study.toml"), "--output", str(self.root / output), "--quiet", *extra]

    def env(self, log: str, fault: str | None = None, full: str | None = None, pids: Path | None = None) -> dict:
        env = {**os.environ, "RC_SOLVE_LOG": str(self.root / log), "OPENBLAS_NUM_THREADS": "1"}
        for name, value in (("RC_FAULT", fault), ("RC_ENOSPC", full), ("RC_PIDS", pids and str(pids))):
            env.pop(name, None)
            if value:
                env[name] = value
        return env

    def run(self, output: str, log: str, fault: str | None = None, timeout: float = 120, full: str | None = None):
        """Run to the end: mpiexec's exit and every rank's (:func:`settle`)."""
        done = subprocess.run(self.command(output), env=self.env(log, fault, full), capture_output=True, text=True,
                              timeout=timeout)
        settle(self.root / output)
        return done

    def start(self, output: str, log: str, pids: Path | None = None, *extra: str, ranks: int = 2,
              capture: bool = False) -> subprocess.Popen:
        pipe = subprocess.PIPE if capture else subprocess.DEVNULL
        return subprocess.Popen(self.command(output, *extra, ranks=ranks), env=self.env(log, pids=pids),
                                start_new_session=True, stdout=pipe, stderr=pipe, text=True)

    def paths(self, output: str) -> dict[int, Path]:
        """The whole task files on disk by task number (read from each file's ``task`` attribute)."""
        import h5py

        out = {}
        for path in (self.root / output / "faults.tasks").glob("task-*.nc"):
            try:
                with h5py.File(path, "r") as f:
                    out[int(f.attrs["task"])] = path
            except (OSError, KeyError):
                continue
        return out

    def files(self, output: str) -> dict[int, bytes]:
        """The bytes of :meth:`paths`."""
        return {index: path.read_bytes() for index, path in self.paths(output).items()}

    def solves(self, log: str) -> list[tuple[int, int, int]]:
        path = self.root / log
        return [tuple(map(int, line.split())) for line in path.read_text().splitlines()] if path.exists() else []

    def kill_after(self, output: str, log: str, files: int, victim) -> None:
        """Start a run and SIGKILL ``victim(process, solves, output path)`` once ``files`` task
        files exist; return once no process of the run is left."""
        process = self.start(output, log)
        deadline = time.monotonic() + 120
        while len(self.files(output)) < files:
            assert process.poll() is None, "the run ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        victim(process, self.solves(log), self.root / output)
        try:
            process.wait(timeout=60)
        finally:
            kill_run(self.root / output, process)


def alive_group(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False


def run_processes(output: Path) -> list[int]:
    """Pids of the live processes whose command line names ``output`` (mpiexec and each rank)."""
    target = str(output).encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            arguments = Path(f"/proc/{entry}/cmdline").read_bytes().split(b"\0")
            state = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue                                     # gone meanwhile
        if target in arguments and state not in ("Z", "X"):
            found.append(int(entry))
    return found


def settle(output: Path, limit: float = 30.0) -> float:
    """Wait until no process of the run on ``output`` is left; the seconds waited. After an abort
    mpiexec may return before MPICH's proxies have killed the other ranks (each in a session of
    its own), which meanwhile can finish one more task file; a rank alive ``limit`` s later is
    killed and reported."""
    start = time.monotonic()
    while pids := run_processes(output):
        if time.monotonic() - start > limit:
            kill_run(output)
            raise RuntimeError(f"processes {pids} of the run on {output} outlived mpiexec by {limit:g} s")
        time.sleep(0.01)
    return time.monotonic() - start


def kill_run(output: Path, process: subprocess.Popen | None = None, limit: float = 30.0) -> None:
    """SIGKILL every process of the run on ``output`` — mpiexec's process group and each rank,
    which runs in a session of its own — and wait until none is left."""
    if process is not None and alive_group(process.pid):
        os.killpg(process.pid, signal.SIGKILL)
    deadline = time.monotonic() + limit
    while pids := run_processes(output):
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        if time.monotonic() > deadline:
            raise RuntimeError(f"processes {pids} of the run on {output} outlived SIGKILL for {limit:g} s")
        time.sleep(0.01)
    if process is not None:
        process.wait()


def scalars(path: Path):
    """The combined root group without wall times (they differ from run to run)."""
    import xarray as xr

    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.drop_vars([v for v in ds.data_vars if "elapsed" in v]).load()


def reference_run(job: Job, hang: float) -> tuple[object, float]:
    """The scalars of an uninterrupted run, and its wall time (s)."""
    start = time.perf_counter()
    run = job.run("reference", "reference.log", timeout=hang)
    if run.returncode != 0:
        raise SystemExit(f"the uninterrupted run failed: {run.stderr}")
    return scalars(job.root / "reference" / "faults.nc"), time.perf_counter() - start


def fault_run(job: Job, kind: str, run: int, rng: random.Random, duration: float, hang: float) -> dict:
    """One run hit by a fault of ``kind``, then resumed; what was lost, recomputed and hung."""
    output, first, second = f"{kind}-{run}", f"{kind}-{run}-first.log", f"{kind}-{run}-second.log"
    row = {"kind": kind, "run": run, "hung": 0}
    if kind in ("kill-job", "kill-rank", "truncate"):
        pids = job.root / f"{output}-pids"
        pids.mkdir()
        delay = rng.uniform(0.05, 1.0) * duration
        row["fault_at_s"] = round(delay, 3)
        process = job.start(output, first, pids)
        try:
            process.wait(timeout=delay)
            row["ended_before_fault"] = True
        except subprocess.TimeoutExpired:
            row["ended_before_fault"] = False
            if kind == "kill-rank" and (pids / "rank-1").exists():
                os.kill(int((pids / "rank-1").read_text()), signal.SIGKILL)
            else:
                kill_run(job.root / output, process)
        try:
            process.wait(timeout=hang)
        except subprocess.TimeoutExpired:
            row["hung"] = 1
        kill_run(job.root / output, process)            # nothing of the run outlives it
    else:
        rank, nth = rng.randrange(2), rng.randrange(TASKS // 2)
        row["fault"] = f"rank {rank}, its task {nth}" if kind == "raise" else f"rank {rank}, its write {nth}"
        try:
            done = job.run(output, first, timeout=hang, **({"fault": f"{rank}:{nth}"} if kind == "raise"
                                                            else {"full": f"{rank}:{nth}"}))
            row["exit_status"] = done.returncode
            row["one_line"] = kind != "enospc" or sum(
                line.startswith("roughcontact:") for line in done.stderr.splitlines()) == 1
        except subprocess.TimeoutExpired:
            row["hung"] = 1
    whole = job.files(output)
    if kind == "truncate" and whole:
        cut = rng.choice(sorted(whole))
        data = whole.pop(cut)
        job.paths(output)[cut].write_bytes(data[: rng.randrange(1, len(data))])
        row["truncated_task"] = cut
    row["whole_after_fault"] = len(whole)
    start = time.perf_counter()
    try:
        resumed = job.run(output, second, timeout=hang)
        row["resume_status"] = resumed.returncode
    except subprocess.TimeoutExpired:
        row["hung"] += 1
        row["resume_status"] = None
    row["resume_s"] = round(time.perf_counter() - start, 2)
    again = {task for task, _, _ in job.solves(second)}
    row["recomputed_beyond_in_flight"] = len(again & set(whole))
    after = job.files(output)
    final = job.root / output / "faults.nc"
    completed = int((scalars(final)["status"] == 0).sum()) if final.exists() else 0
    row["lost"] = sum(after.get(i) != data for i, data in whole.items()) + (TASKS - completed)
    row["resumed_solves"] = len(again)
    return row


def equal_to(reference, path: Path, tolerance: float = 1e-12) -> bool:
    if not path.exists():
        return False
    ds = scalars(path)
    if set(ds.data_vars) != set(reference.data_vars):
        return False
    for name in reference.data_vars:
        a, b = np.asarray(reference[name].values), np.asarray(ds[name].values)
        if a.dtype.kind in "fc":
            scale = np.nanmax(np.abs(a)) if np.isfinite(a).any() else 1.0
            if not np.allclose(a, b, rtol=0, atol=tolerance * max(scale, 1e-300), equal_nan=True):
                return False
        elif not np.array_equal(a, b):
            return False
    return True


def fault_struck(row: dict) -> bool:
    """Whether the fault hit the run before it ended (a random moment may come after the end)."""
    if "ended_before_fault" in row:
        return not row["ended_before_fault"]
    return row.get("exit_status") not in (0, None) or bool(row["hung"])


def campaign(root: Path, runs: int, seed: int = 2026, hang: float = 120.0, log=print) -> dict:
    """``runs`` fault runs of each kind under ``root``; the per-kind table and every run's row."""
    job = Job(root)
    reference, duration = reference_run(job, hang)
    log(f"uninterrupted run: {duration:.1f} s")
    rng = random.Random(seed)
    rows = []
    for run in range(runs):
        for kind in KINDS:
            row = fault_run(job, kind, run, rng, duration, hang)
            row["equal"] = equal_to(reference, job.root / f"{kind}-{run}" / "faults.nc")
            rows.append(row)
            log(f"{kind:9s} run {run}: {row['whole_after_fault']:2d} whole after the fault, resume solved "
                f"{row['resumed_solves']:2d} ({row['resume_s']} s), lost {row['lost']}, recomputed "
                f"{row['recomputed_beyond_in_flight']}, hung {row['hung']}, equal {row['equal']}")
    table = {}
    for kind in KINDS:
        mine = [r for r in rows if r["kind"] == kind]
        table[kind] = {"runs": len(mine), "struck_before_the_end": sum(fault_struck(r) for r in mine),
                       "tasks_lost": sum(r["lost"] for r in mine),
                       "recomputed_beyond_in_flight": sum(r["recomputed_beyond_in_flight"] for r in mine),
                       "hangs": sum(r["hung"] for r in mine),
                       "equal_to_uninterrupted": sum(bool(r["equal"]) for r in mine),
                       "resumes_exit_0": sum(r.get("resume_status") == 0 for r in mine),
                       "one_line_on_stderr": sum(bool(r.get("one_line", True)) for r in mine)}
    return {"tasks": TASKS, "ranks": 2, "uninterrupted_s": round(duration, 2), "seed": seed, "table": table,
            "rows": rows}


def main() -> None:
    from benchmarks.common import save_json

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=6, help="runs of each fault kind (default 6: 30 runs)")
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--hang", type=float, default=120.0, help="seconds after which a run counts as hung")
    parser.add_argument("--output", default="results/bench_faults.json")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="faults-") as root:
        report = campaign(Path(root), args.runs, args.seed, args.hang)
    print("| fault | runs | struck before the end | tasks lost | recomputed beyond in flight | hangs | "
          "equal to uninterrupted (1e-12) |")
    print("|---|---|---|---|---|---|---|")
    for kind, row in report["table"].items():
        print(f"| {kind} | {row['runs']} | {row['struck_before_the_end']} | {row['tasks_lost']} | "
              f"{row['recomputed_beyond_in_flight']} | "
              f"{row['hangs']} | {row['equal_to_uninterrupted']}/{row['runs']} |")
    save_json(report, args.output)


if __name__ == "__main__":
    main()
