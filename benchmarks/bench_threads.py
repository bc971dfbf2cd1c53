#!/usr/bin/env python3
"""A normal solve with OpenBLAS's default threads, against one BLAS thread during the solve.

A program that imports the package as a library, with nothing in its
environment, gets OpenBLAS's default of one thread per core in numpy and
PETSc. Each solve limits them to one (:mod:`roughcontact.threads`); this
benchmark measures what that limit saves by running the same solve with it
(``limited``, the package as it is) and without it (``default``: the limit
replaced by a no-op in the worker), alternately, ``--repeats`` times each,
on each rank count, OPENBLAS_NUM_THREADS left to the cores of the machine.
The scene is the large-grid one (benchmarks.common.scene_surface, 0.01 E*,
CG with its defaults, set-up included).

    python -m benchmarks.bench_threads [--sizes 1024] [--ranks 1 2] [--repeats 3]
        [--output results/bench_threads.json]
"""
from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import time

from benchmarks.common import (
    add_launch_arguments,
    emit,
    run_on_ranks,
    save_json,
    scene_problem,
    scene_topography,
    solve_scene,
    worker_mpi,
    write_rows,
)


def worker(args) -> None:
    MPI = worker_mpi()

    import roughcontact.normal.solver as solver_module

    comm = MPI.COMM_WORLD
    limited = solver_module.single_blas_thread
    arms = {"limited": limited, "default": contextlib.nullcontext}
    rows: list[dict] = []
    for n in args.sizes:
        topography = scene_topography(n)
        times: dict[str, list[float]] = {arm: [] for arm in arms}
        for _ in range(args.repeats):
            for arm, limit in arms.items():
                solver_module.single_blas_thread = limit
                comm.Barrier()
                start = time.perf_counter()
                problem = scene_problem(topography, comm)
                result = solve_scene(problem)
                problem.destroy()
                times[arm].append(comm.allreduce(time.perf_counter() - start, op=MPI.MAX))
        solver_module.single_blas_thread = limited
        medians = {arm: statistics.median(t) for arm, t in times.items()}
        emit(comm, rows, {
            "n": n, "ranks": comm.Get_size(), "blas_threads_default": os.environ.get("OPENBLAS_NUM_THREADS"),
            "limited_s": round(medians["limited"], 3), "default_s": round(medians["default"], 3),
            "default_over_limited": round(medians["default"] / medians["limited"], 2),
            "times": {arm: [round(t, 3) for t in ts] for arm, ts in times.items()},
            "iterations": result.linear_iterations})
    write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_launch_arguments(parser, repeats=3, output="results/bench_threads.json")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024])
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    # OpenBLAS's own default, one thread per core (run_on_ranks would otherwise ask for one)
    os.environ["OPENBLAS_NUM_THREADS"] = str(len(os.sched_getaffinity(0)))
    rows = run_on_ranks(__spec__.name, args.ranks, ["--repeats", str(args.repeats),
                                                    "--sizes", *map(str, args.sizes)])
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
