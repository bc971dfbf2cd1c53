#!/usr/bin/env python3
"""Which operator and method a small task should use: the measured crossover behind ``auto``.

A task of an ensemble: build the problem, then a warm-started sweep of 12
loads (0.005 % to 0.5 % of E* A0, the default study's range of contact) on a
midpoint-displacement surface (Δ = 2.3), with the rotation free (the
default of ``solve_load``) and fixed. For each grid (17² to 257²), operator
(dense, fft) and method (ksp, cg): the wall time of the whole task, median
of ``--repeats``, on one rank. The dense operator stops at 129² (257² would
need 35 GB).

    python -m benchmarks.bench_crossover [--levels 4 5 6 7 8] [--methods ksp cg]
        [--output results/bench_crossover.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import ensemble_task, save_json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[4, 5, 6, 7, 8])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--methods", nargs="+", choices=["ksp", "cg"], default=["ksp", "cg"])
    parser.add_argument("--output", default="results/bench_crossover.json")
    args = parser.parse_args()

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.normal import NormalProblem, make_solver

    rows = []
    for levels in args.levels:
        topo, rock, loads = ensemble_task(levels)
        n = topo.shape[0]
        for operator in ("dense", "fft"):
            if operator == "dense" and n > 129:
                continue
            for method in args.methods:
                for rotation in ("free", "fixed"):
                    times, fraction = [], None
                    for _ in range(args.repeats):
                        t0 = time.perf_counter()
                        problem = NormalProblem(topo, rock, MPI.COMM_SELF, operator=operator)
                        with make_solver(problem, method) as solver:
                            for load in loads:
                                result = solver.solve_load(load, rotation=None if rotation == "free" else (0.0, 0.0))
                        problem.destroy()
                        times.append(time.perf_counter() - t0)
                        fraction = result.contact_fraction
                    row = {"n": n, "operator": operator, "method": method, "rotation": rotation,
                           "seconds": float(np.median(times)), "last_contact_fraction": fraction}
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
