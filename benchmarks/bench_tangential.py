#!/usr/bin/env python
"""Benchmark of tangential sweeps: what a Q sweep of N steps costs relative to one normal solve.

A random-midpoint-displacement surface (Δ = 2.3) between two identical ν = 0
half-spaces is pressed by a load P reaching about 8 % real contact; the
reference is the actual normal solve at P (load control, free rotation, a
fresh solver: what a user runs before the sweep). Each sweep runs Q = k fP/N,
k = 0 … N − 1, plus the incipient-sliding limit, with one corrective solver
warm-started from step to step (Eq. 23). Also timed: one corrective solve
from a cold start (fixed rotation, P* = P/2), the unit each step would cost
without warm starts. Times are medians of --repeats runs in this invocation.

    python -m benchmarks.bench_tangential                        # writes results/bench_tangential.json
    python -m benchmarks.bench_tangential --sizes 33 --ranks 1   # a quicker look
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from benchmarks.common import add_launch_arguments, emit, run_on_ranks, sweep_scene, write_rows


def worker(args) -> None:
    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.normal import ActiveSetSolver, NormalProblem
    from roughcontact.tangential import tangential_sweep

    comm = MPI.COMM_WORLD
    friction = 0.6
    rows = []
    for n in args.sizes:
        topo, interface, closure = sweep_scene(n)
        problem = NormalProblem(topo, interface, comm)
        with ActiveSetSolver(problem) as solver:
            load = solver.solve_closure(closure).load

        def timed(fn):
            comm.Barrier()
            t0 = time.perf_counter()
            out = fn()
            comm.Barrier()
            return time.perf_counter() - t0, out

        normal_times, normal = [], None
        for _ in range(args.repeats):
            with ActiveSetSolver(problem) as solver:
                dt, normal = timed(lambda: solver.solve_load(load))
            normal_times.append(dt)
        cold_times, cold = [], None
        for _ in range(args.repeats):
            with ActiveSetSolver(problem, prefix="cattaneo_") as solver:
                dt, cold = timed(lambda: solver.solve_load(load / 2.0, rotation=normal.rotation))
            cold_times.append(dt)
        row = {
            "nodes_per_side": n, "unknowns": n * n, "ranks": comm.Get_size(),
            "load_N": load, "contact_fraction": normal.contact_fraction,
            "normal_solve_s_median": float(np.median(normal_times)),
            "normal_outer_iterations": normal.outer_iterations,
            "normal_linear_iterations": normal.linear_iterations,
            "cold_corrective_solve_s_median": float(np.median(cold_times)),
            "cold_corrective_outer_iterations": cold.outer_iterations,
            "cold_corrective_linear_iterations": cold.linear_iterations,
            "sweeps": [],
        }
        for steps in args.steps:
            sweep_times, sweep = [], None
            for _ in range(args.repeats):
                dt, sweep = timed(lambda: tangential_sweep(problem, normal, friction, steps=steps))
                sweep_times.append(dt)
            correctives = [s.corrective for s in sweep.states[1:] if s.corrective is not None]
            median = float(np.median(sweep_times))
            row["sweeps"].append({
                "steps": steps, "sweep_s_median": median,
                "sweep_over_normal_solve": median / row["normal_solve_s_median"],
                "per_step_over_cold_corrective": median / steps / row["cold_corrective_solve_s_median"],
                "corrective_outer_iterations_mean": float(np.mean([c.outer_iterations for c in correctives])),
                "corrective_linear_iterations_mean": float(np.mean([c.linear_iterations for c in correctives])),
                "resticking_nodes": sweep.resticking_nodes,
            })
        problem.destroy()
        emit(comm, rows, row)
    write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[33, 65])
    parser.add_argument("--steps", type=int, nargs="+", default=[10, 20, 40])
    add_launch_arguments(parser, repeats=5, output="results/bench_tangential.json")
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    rows = run_on_ranks(__spec__.name, args.ranks, ["--repeats", str(args.repeats), "--sizes", *map(str, args.sizes),
                   "--steps", *map(str, args.steps)])
    report = {"benchmark": "tangential sweep Q = 0 ... fP in N steps (+ the incipient-sliding limit) "
                           "against one normal solve (load control, free rotation, cold start)",
              "machine": {"cpus": os.cpu_count()}, "repeats": args.repeats, "rows": rows}
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(json.dumps(report, indent=1))
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
