#!/usr/bin/env python3
"""Which operator and method a small task should use: the measured crossover behind ``auto``.

A task of an ensemble: build the problem, then a warm-started sweep of 12
loads (0.005 % to 0.5 % of E* A0, the default study's range of contact) on a
midpoint-displacement surface (Δ = 2.3, ``--levels``: 2^levels + 1 nodes a
side) or a non-periodic Fourier surface of the same Δ (``--sizes``: any n,
the grids between the midpoint's), with the rotation free (the default of
``solve_load``) and fixed. For each grid, seed (``--seeds``), operator
(dense, fft) and method (ksp, cg): the wall time of the whole task, median
of ``--repeats``, on one rank; the ways of one grid and rotation alternate
within each repeat (reversed on odd ones), so that the machine's drift
falls on all of them. The dense operator stops at 129² (257² would need
35 GB).

    python -m benchmarks.bench_crossover [--levels 4 5 6 7 8] [--sizes 40 48]
        [--seeds 1] [--methods ksp cg] [--output results/bench_crossover.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import alternated, ensemble_task, fourier_task, save_json


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", type=int, nargs="*", default=[4, 5, 6, 7, 8])
    parser.add_argument("--sizes", type=int, nargs="*", default=[])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--methods", nargs="+", choices=["ksp", "cg"], default=["ksp", "cg"])
    parser.add_argument("--output", default="results/bench_crossover.json")
    args = parser.parse_args()

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.normal import NormalProblem, make_solver

    tasks = [("midpoint", lambda seed, levels=levels: ensemble_task(levels, seed)) for levels in args.levels]
    tasks += [("fourier", lambda seed, n=n: fourier_task(n, seed)) for n in args.sizes]
    rows = []
    for surface, task in tasks:
        for seed in args.seeds:
            topo, rock, loads = task(seed)
            n = topo.shape[0]
            ways = [(operator, method) for operator in ("dense", "fft") for method in args.methods
                    if operator == "fft" or n <= 129]
            for rotation in ("free", "fixed"):
                times = {way: [] for way in ways}
                fraction = {}
                for repeat in range(args.repeats):
                    for operator, method in alternated(ways, repeat):
                        t0 = time.perf_counter()
                        problem = NormalProblem(topo, rock, MPI.COMM_SELF, operator=operator)
                        with make_solver(problem, method) as solver:
                            for load in loads:
                                result = solver.solve_load(load, rotation=None if rotation == "free" else (0.0, 0.0))
                        problem.destroy()
                        times[operator, method].append(time.perf_counter() - t0)
                        fraction[operator, method] = result.contact_fraction
                for operator, method in ways:
                    row = {"n": n, "surface": surface, "seed": seed, "operator": operator, "method": method,
                           "rotation": rotation, "seconds": float(np.median(times[operator, method])),
                           "last_contact_fraction": fraction[operator, method]}
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
