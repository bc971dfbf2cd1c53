#!/usr/bin/env python
"""Benchmark of the ensemble farm: throughput on 1 and 2 ranks, overhead per task, the leaders' writes.

Ensembles of random-midpoint surfaces (Δ = 2.3, ν = 0 half-spaces):

- ``small``: 64 tasks of 33 × 33 nodes and 6 loads (tens of ms each), fields "all";
- ``long``: 16 tasks of 65 × 65 nodes and 32 loads (about a second each), fields "contact";
- ``scaling`` (only when named): 64 tasks of 129 × 129 nodes and 6 loads, fields "contact",
  enough to keep 16 ranks busy for strong scaling on a larger machine::

      python -m benchmarks.bench_farm --cases scaling --ranks 1 2 4 8 16 --repeats 1 --no-bare --bind-to core

For each, the farm (``run_study``: checks, the farm, a task file per task,
the combined dataset and figure) is timed on each rank count, and on one
rank the bare loop of the same solves (``solve_task`` on COMM_SELF, no
files). Reported, medians of --repeats runs in one invocation:

- tasks/s = tasks / wall time of the run;
- overhead per task (ms) = (farm on 1 rank − bare loop) / tasks, for the whole run and for
  the farm phase alone (tasks solved, encoded and written; without the checks before it and
  the combined dataset and figure after it, which rank 0 does alone);
- parallel efficiency on n ranks = wall(1 rank) / (n · wall(n ranks)), whole run and farm phase;
- utilisation = time the ranks spend solving and encoding tasks / (n · farm phase): what the
  farm's scheduling loses, whatever else shares the machine's cores;
- write throughput = bytes of task files / time the group leaders spend encoding and writing
  them (each leader writes its own tasks' files, fsync included).

    python -m benchmarks.bench_farm                  # writes results/bench_farm.json
    python -m benchmarks.bench_farm --repeats 1      # a quicker look
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from benchmarks.common import add_launch_arguments, emit, run_on_ranks, save_json, write_rows

CASES = {
    "small": {"levels": 5, "seeds": 64, "loads": list(np.linspace(20.0, 120.0, 6)), "fields": "all"},
    "long": {"levels": 6, "seeds": 16, "loads": list(np.linspace(25.0, 1000.0, 32)), "fields": "contact"},
    # strong scaling over up to 16 ranks (bench_scaling): tasks enough to keep 16 ranks busy
    "scaling": {"levels": 7, "seeds": 64, "loads": list(np.linspace(50.0, 1000.0, 6)), "fields": "contact"},
}
#: what a run without --cases measures
DEFAULT_CASES = ["small", "long"]


def study_of(name: str) -> dict:
    case = CASES[name]
    return {"name": f"bench-{name}",
            "surface": {"generator": "midpoint", "levels": case["levels"], "spacing": 1e-4, "rms_height": 1e-5,
                        "fractal_dimension": 2.3},
            "axes": {"seeds": case["seeds"]},
            "materials": {"body1": {"E": 20e9, "nu": 0.0}, "body2": {"E": 20e9, "nu": 0.0}},
            "normal": {"loads": [round(float(p), 3) for p in case["loads"]]},
            "output": {"fields": case["fields"]}}


def worker(args) -> None:
    import petsc4py
    from mpi4py import MPI  # first: MPI with threads, as the command line starts it

    petsc4py.init([])
    from roughcontact.farm import load_study, run_study, solve_task
    from roughcontact.farm.store import TaskStore

    comm = MPI.COMM_WORLD
    writes = {"seconds": 0.0, "bytes": 0}
    write_task = TaskStore.write_task

    def timed_write(self, task, groups):           # a leader's encode and write, as the farm makes them
        t0 = time.perf_counter()
        written = write_task(self, task, groups)
        writes["seconds"] += time.perf_counter() - t0
        writes["bytes"] += written.size
        return written

    TaskStore.write_task = timed_write
    import roughcontact.farm.run as run_module

    farm_phase = {"seconds": 0.0}
    run_farm = run_module.run_farm

    def timed_farm(*a, **k):                          # the farm alone: tasks solved and written
        t0 = time.perf_counter()
        run_farm(*a, **k)
        farm_phase["seconds"] = time.perf_counter() - t0

    run_module.run_farm = timed_farm
    busy = {"seconds": 0.0}                         # time this rank spends solving, encoding and writing tasks

    def timed(function):
        def wrapper(*a, **k):
            t0 = time.perf_counter()
            try:
                return function(*a, **k)
            finally:
                busy["seconds"] += time.perf_counter() - t0
        return wrapper

    run_module.solve_task = timed(run_module.solve_task)
    TaskStore.write_task = timed(TaskStore.write_task)
    rows = []
    for name in args.cases:
        study = load_study(study_of(name))
        tasks = study.tasks()
        walls, farms, written, write_s, utilisation = [], [], [], [], []
        for _ in range(args.repeats):
            writes.update(seconds=0.0, bytes=0)
            busy["seconds"] = 0.0
            with tempfile.TemporaryDirectory() as tmp:
                output = comm.bcast(tmp, root=0)
                comm.Barrier()
                t0 = time.perf_counter()
                summary = run_study(study, comm, output, log=lambda *a: None, quiet=True)
                comm.Barrier()
                walls.append(time.perf_counter() - t0)
                farms.append(comm.allreduce(farm_phase["seconds"], op=MPI.MAX))
                utilisation.append(comm.allreduce(busy["seconds"]) / (comm.Get_size() * farms[-1]))
                comm.Barrier()
            assert summary.solved == len(tasks) and not summary.failed
            written.append(comm.allreduce(writes["bytes"]))
            write_s.append(comm.allreduce(writes["seconds"]))
        row = {"case": name, "ranks": comm.Get_size(), "tasks": len(tasks),
               "grid": f"{2 ** CASES[name]['levels'] + 1}^2", "loads": len(study.loads), "fields": study.fields,
               "wall_s_median": float(np.median(walls)), "tasks_per_s": len(tasks) / float(np.median(walls)),
               "farm_phase_s_median": float(np.median(farms)),
               "farm_utilisation_median": float(np.median(utilisation)),
               "task_files_MB": float(np.median(written)) / 1e6,
               "write_s_median": float(np.median(write_s)),
               "write_MB_per_s": float(np.median(written)) / 1e6 / max(float(np.median(write_s)), 1e-9)}
        if comm.Get_size() == 1 and args.bare:
            bare = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                for task in tasks:
                    solve_task(task, MPI.COMM_SELF)
                bare.append(time.perf_counter() - t0)
            row["bare_loop_s_median"] = float(np.median(bare))
            row["bare_task_s_median"] = row["bare_loop_s_median"] / len(tasks)
            row["overhead_ms_per_task"] = 1e3 * (row["wall_s_median"] - row["bare_loop_s_median"]) / len(tasks)
            row["farm_phase_overhead_ms_per_task"] = (
                1e3 * (row["farm_phase_s_median"] - row["bare_loop_s_median"]) / len(tasks))
        emit(comm, rows, row)
    write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=DEFAULT_CASES, choices=list(CASES))
    parser.add_argument("--no-bare", dest="bare", action="store_false",
                        help="skip the bare serial loop on one rank (the overhead per task)")
    add_launch_arguments(parser, repeats=3, output="results/bench_farm.json", binding=True)
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")     # one BLAS thread per rank
    rows = run_on_ranks(__spec__.name, args.ranks, ["--repeats", str(args.repeats), "--cases", *args.cases]
                        + ([] if args.bare else ["--no-bare"]), bind_to=args.bind_to)
    summary = []
    for name in args.cases:
        by_ranks = {r["ranks"]: r for r in rows if r["case"] == name}
        one = by_ranks.get(1)
        for n, row in sorted(by_ranks.items()):
            if one and n > 1:
                row["parallel_efficiency"] = one["wall_s_median"] / (n * row["wall_s_median"])
                row["farm_phase_efficiency"] = one["farm_phase_s_median"] / (n * row["farm_phase_s_median"])
            summary.append(row)
            print(f"{name:6s} {n} rank(s): {row['tasks_per_s']:7.2f} tasks/s, wall {row['wall_s_median']:6.2f} s"
                  + (f", bare task {1e3 * row['bare_task_s_median']:.0f} ms, overhead "
                     f"{row['overhead_ms_per_task']:.1f} ms/task" if "overhead_ms_per_task" in row else "")
                  + (f", efficiency {row['parallel_efficiency']:.2f} (farm phase "
                     f"{row['farm_phase_efficiency']:.2f})" if "parallel_efficiency" in row else "")
                  + f", ranks busy {row['farm_utilisation_median']:.0%} of the farm phase"
                  + f", leaders write {row['write_MB_per_s']:.0f} MB/s ({row['task_files_MB']:.1f} MB)")
    report = {"benchmark": "ensemble farm: run_study on each rank count (and a bare serial loop of the solves "
                           "on one rank unless --no-bare)",
              "machine": {"cpus": os.cpu_count()}, "bind_to": args.bind_to, "repeats": args.repeats,
              "cases": CASES, "rows": summary}
    save_json(report, args.output)


if __name__ == "__main__":
    main()
