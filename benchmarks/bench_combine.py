#!/usr/bin/env python
"""Benchmark of the farm at many small tasks and of the combine, for two versions of the code.

Two studies of random-midpoint surfaces (Δ = 2.3, ν = 0 half-spaces):

- ``many``: 10 000 tasks of 33² nodes, one load, fields "contact" (the default);
  solved on 2 ranks with ``run_study``: wall time split into the checks before
  the farm, the farm (tasks solved and written; throughput = tasks / farm time)
  and what follows it, when rank 0 alone works while the others wait (the
  combined dataset and the figure); rank 0's peak memory (ru_maxrss) before and
  after the combine. Then ``combine_study`` (what ``roughcontact combine`` does,
  one process) on the first 1000, 3000 and 10 000 tasks: time and peak memory
  above the process's memory before it, fitted as a + b·n and extrapolated to
  10⁵ tasks.
- ``fields``: 256 tasks of 129² nodes, 12 loads, fields "all" (5.0 MB of fields
  per task in memory, 1.28 GB in all); solved on 2 ranks, then combined by one
  process whose memory is limited to ``--limit`` MB (a child memory cgroup when
  one can be made, else ``ulimit -v`` above the process's address space at start):
  fields of more than 4 times the memory given.

``--code DIR`` runs the same measurements with the ``roughcontact`` of another
checkout (an earlier commit, for a before/after in one run): workers start as
this file with ``PYTHONPATH=DIR``, so only the package changes.

    python -m benchmarks.bench_combine                          # writes results/bench_combine.json
    python -m benchmarks.bench_combine --code /tmp/old --label before --output results/bench_combine_before.json
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()
SIZES = (1000, 3000, 10000)


def study(name: str, tasks: int) -> dict:
    if name == "many":
        surface, loads, fields = {"levels": 5}, [60.0], "contact"
    else:
        surface, loads, fields = {"levels": 7}, [float(p) for p in range(100, 1300, 100)], "all"
    return {"name": f"bench-combine-{name}",
            "surface": {"generator": "midpoint", "spacing": 1e-4, "rms_height": 1e-5, "fractal_dimension": 2.3,
                        **surface},
            "axes": {"seeds": tasks},
            "materials": {"body1": {"E": 20e9, "nu": 0.0}, "body2": {"E": 20e9, "nu": 0.0}},
            "normal": {"loads": loads}, "output": {"fields": fields}}


def rss_now() -> int:
    """Resident bytes of this process now."""
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def peak_rss() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def figure_timer(marks: dict) -> None:
    """Import the plotting stack now (its memory is not the combine's) and time the figure the
    run draws after the combined dataset, so that the combine's own time is measured."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401

    import roughcontact.analysis.figures as figures

    draw = figures.contact_area_vs_load

    def timed(*a, **k):
        t = time.perf_counter()
        try:
            return draw(*a, **k)
        finally:
            marks["figure"] = marks.get("figure", 0.0) + time.perf_counter() - t

    figures.contact_area_vs_load = timed


def worker_run(args) -> None:
    """Under mpiexec: one run_study, its phases timed on rank 0."""
    import petsc4py
    from mpi4py import MPI

    petsc4py.init([])
    import roughcontact
    import roughcontact.farm.run as run_module
    from roughcontact.farm import load_study, run_study

    comm = MPI.COMM_WORLD
    marks = {}
    figure_timer(marks)
    farm, finish = run_module.run_farm, run_module._finish

    def timed_farm(*a, **k):
        marks["farm_start"] = time.perf_counter()
        try:
            return farm(*a, **k)
        finally:
            marks["farm_end"] = time.perf_counter()

    def timed_finish(*a, **k):
        marks["peak_before_combine"] = peak_rss()
        t = time.perf_counter()
        try:
            return finish(*a, **k)
        finally:
            marks["combine"] = time.perf_counter() - t
            marks["peak_after_combine"] = peak_rss()

    run_module.run_farm, run_module._finish = timed_farm, timed_finish
    definition = load_study(study(args.case, args.tasks))
    comm.Barrier()
    t0 = time.perf_counter()
    summary = run_study(definition, comm, args.dir, log=lambda *a, **k: None, quiet=True)
    t1 = time.perf_counter()
    if comm.Get_rank() == 0:
        row = {"case": args.case, "tasks": args.tasks, "ranks": comm.Get_size(), "solved": summary.solved,
               "wall_s": t1 - t0, "before_farm_s": marks["farm_start"] - t0,
               "farm_s": marks["farm_end"] - marks["farm_start"], "after_farm_s": t1 - marks["farm_end"],
               "combine_s": marks.get("combine", 0) - marks.get("figure", 0), "figure_s": marks.get("figure"),
               "tasks_per_s": summary.solved / (marks["farm_end"] - marks["farm_start"]),
               "rank0_peak_before_combine_MB": marks.get("peak_before_combine", 0) / 1e6,
               "rank0_peak_after_combine_MB": marks.get("peak_after_combine", 0) / 1e6,
               "code": str(Path(roughcontact.__file__).parent.parent)}
        Path(args.json).write_text(json.dumps(row))


def worker_combine(args) -> None:
    """One process: combine_study of the first ``tasks`` tasks, its time and memory."""
    import petsc4py
    from mpi4py import MPI  # noqa: F401

    petsc4py.init([])
    import roughcontact
    from roughcontact.farm import load_study
    from roughcontact.farm.run import combine_study

    marks = {}
    figure_timer(marks)
    definition = load_study(study(args.case, args.tasks))
    base, t = rss_now(), time.perf_counter()
    try:
        summary = combine_study(definition, args.dir, log=lambda *a, **k: None)
        outcome = {"missing": len(summary.missing), "failed": len(summary.failed)}
    except MemoryError:
        outcome = {"error": "MemoryError"}
    elapsed = time.perf_counter() - t - marks.get("figure", 0)
    Path(args.json).write_text(json.dumps({
        "case": args.case, "tasks": args.tasks, "combine_s": elapsed, "figure_s": marks.get("figure"), "rss_before_MB": base / 1e6,
        "peak_MB": peak_rss() / 1e6, "held_MB": (peak_rss() - base) / 1e6, **outcome,
        "code": str(Path(roughcontact.__file__).parent.parent)}))


def launch(code: str, mode: str, case: str, tasks: int, directory: Path, ranks: int = 0,
           limit_mb: int = 0) -> dict:
    """Run a worker of ``code`` (under mpiexec with ``ranks`` > 0), its row (or how it died)."""
    from benchmarks.common import mpiexec

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "row.json"
        cmd = [sys.executable, str(HERE), f"--{mode}", "--case", case, "--tasks", str(tasks),
               "--dir", str(directory), "--json", str(out)]
        if ranks:
            cmd = [mpiexec(), "-n", str(ranks), *cmd]
        env = dict(os.environ, PYTHONPATH=code, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
        cgroup, preexec = (memory_limit(limit_mb) if limit_mb else (None, None))
        t = time.perf_counter()
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, preexec_fn=preexec)
        wall = time.perf_counter() - t
        if cgroup is not None:
            cgroup.rmdir()
        if done.returncode or not out.exists():
            return {"case": case, "tasks": tasks, "mode": mode, "exit_status": done.returncode, "wall_s": wall,
                    "limit_MB": limit_mb or None, "how": limit_how(cgroup, limit_mb),
                    "stderr_tail": done.stderr.strip().splitlines()[-3:]}
        row = json.loads(out.read_text())
        row.update(exit_status=0, limit_MB=limit_mb or None, how=limit_how(cgroup, limit_mb))
        return row


def limit_how(cgroup, limit_mb):
    if not limit_mb:
        return None
    return f"cgroup {cgroup}" if cgroup is not None else "ulimit -v (address space)"


def memory_limit(limit_mb: int):
    """(cgroup directory, preexec function) putting the child under ``limit_mb`` MB: a child of
    this process's own memory cgroup (v1 or v2) when it can be made, else RLIMIT_AS."""
    own = [line.split(":", 2) for line in Path("/proc/self/cgroup").read_text().splitlines()]
    for _, controllers, path in own:
        if "memory" in controllers.split(",") or controllers == "":
            base = Path("/sys/fs/cgroup") / ("memory" if controllers else "") / path.lstrip("/")
            limit_file = "memory.limit_in_bytes" if controllers else "memory.max"
            try:
                group = base / f"bench-combine-{os.getpid()}"
                group.mkdir(exist_ok=True)
                (group / limit_file).write_text(str(limit_mb * 10**6))
            except OSError:
                continue
            swap = group / ("memory.memsw.limit_in_bytes" if controllers else "memory.swap.max")
            try:
                swap.write_text(str(limit_mb * 10**6) if controllers else "0")
            except OSError:
                pass                                   # no swap accounting: nothing to limit
            procs = group / "cgroup.procs"
            return group, lambda: procs.write_text(str(os.getpid()))
    import re

    vm = int(re.search(r"VmSize:\s+(\d+)", Path("/proc/self/status").read_text()).group(1)) * 1024
    return None, lambda: resource.setrlimit(resource.RLIMIT_AS, (vm + limit_mb * 10**6,) * 2)


def fit(rows: list[dict], key: str) -> dict:
    """Least squares a + b n of ``key`` over the rows, and its value at 10⁵ tasks."""
    import numpy as np

    n = np.array([r["tasks"] for r in rows], float)
    y = np.array([r[key] for r in rows], float)
    b, a = np.polyfit(n, y, 1)
    return {"a": a, "b_per_task": b, "at_100000": a + b * 1e5}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--code", default=str(HERE.parent.parent), help="checkout whose roughcontact runs")
    parser.add_argument("--label", default="after")
    parser.add_argument("--output", default="results/bench_combine.json")
    parser.add_argument("--tasks", type=int, default=10000, help="tasks of the 'many' study")
    parser.add_argument("--field-tasks", type=int, default=256, help="tasks of the 'fields' study")
    parser.add_argument("--limit", type=int, default=300, help="MB given to the combine of 'fields'")
    parser.add_argument("--run", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--combine", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--case", help=argparse.SUPPRESS)
    parser.add_argument("--dir", help=argparse.SUPPRESS)
    parser.add_argument("--json", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.run:
        return worker_run(args)
    if args.combine:
        return worker_combine(args)

    from benchmarks.common import save_json

    report = {"label": args.label, "code": args.code}
    with tempfile.TemporaryDirectory(dir=os.environ.get("BENCH_TMP")) as tmp:
        many = Path(tmp) / "many"
        report["many_run"] = launch(args.code, "run", "many", args.tasks, many, ranks=2)
        print(json.dumps(report["many_run"]), flush=True)
        sizes = [n for n in SIZES if n < args.tasks] + [args.tasks]
        report["many_combine"] = [launch(args.code, "combine", "many", n, many) for n in sizes]
        for row in report["many_combine"]:
            print(json.dumps(row), flush=True)
        ok = [r for r in report["many_combine"] if not r["exit_status"]]
        if len(ok) >= 3:
            report["combine_time_fit"] = fit(ok, "combine_s")
            report["combine_memory_fit"] = fit(ok, "held_MB")
        fields = Path(tmp) / "fields"
        report["fields_run"] = launch(args.code, "run", "fields", args.field_tasks, fields, ranks=2)
        print(json.dumps(report["fields_run"]), flush=True)
        report["fields_in_memory_MB"] = args.field_tasks * 12 * 129**2 * (3 * 8 + 1) / 1e6
        report["fields_combine_limited"] = launch(args.code, "combine", "fields", args.field_tasks, fields,
                                                  limit_mb=args.limit)
        print(json.dumps(report["fields_combine_limited"]), flush=True)
    save_json(report, args.output)


if __name__ == "__main__":
    main()
