#!/usr/bin/env python3
"""Iterations saved by the coarse-to-fine start and by warm starts along a load sweep (constrained CG).

The large-grid scene (Fourier filtered, Hurst 0.8, unit rms slope, cut-off
at 8 s, non-periodic, E* = 1), one rank:

- **nested**: one cold solve at 0.01 E*, from independent punches (Winkler)
  or from the solution at 2s, 4s, … (down to 64²): fine iterations, coarse
  iterations (each coarse iteration costs a quarter of the one above), wall
  time;
- **sweep**: 8 loads from 0.002 to 0.02 E*, each solve started from the
  previous one (warm) or cold (nested start): iterations and wall time of
  the whole sweep.

    python -m benchmarks.bench_starts [--sizes 256 512 1024] [--output results/bench_starts.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import save_json, scene_surface


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024])
    parser.add_argument("--output", default="results/bench_starts.json")
    args = parser.parse_args()

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import NormalProblem, make_solver

    rows = []
    for n in args.sizes:
        topo = scene_surface(n)
        problem = NormalProblem(topo, Interface(Material(1.0, 0.0)), MPI.COMM_SELF, operator="fft")
        for nested in (False, True):
            with make_solver(problem, "cg", nested=nested) as solver:
                t0 = time.perf_counter()
                result = solver.solve_load(0.01, rotation=(0.0, 0.0))
                row = {"case": "cold solve", "n": n, "start": "nested" if nested else "Winkler",
                       "fine_iterations": result.linear_iterations, "coarse_iterations": result.coarse_iterations,
                       "seconds": time.perf_counter() - t0}
            rows.append(row)
            print(json.dumps(row), flush=True)
        loads = np.linspace(0.002, 0.02, 8)
        for warm in (True, False):
            its, t0 = 0, time.perf_counter()
            for k, load in enumerate(loads):
                if warm and k:
                    result = solver.solve_load(load, rotation=(0.0, 0.0))
                else:
                    if k:
                        solver.destroy()
                    solver = make_solver(problem, "cg")
                    result = solver.solve_load(load, rotation=(0.0, 0.0))
                its += result.linear_iterations
            solver.destroy()
            row = {"case": "sweep of 8 loads", "n": n, "start": "warm" if warm else "cold (nested)",
                   "fine_iterations": its, "seconds": time.perf_counter() - t0}
            rows.append(row)
            print(json.dumps(row), flush=True)
        problem.destroy()
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
