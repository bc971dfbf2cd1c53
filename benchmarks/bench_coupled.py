#!/usr/bin/env python
"""Benchmark: a coupled tangential sweep (γ ≠ 0, Eqs. 15–16) against the uncoupled Cattaneo sweep.

A random-midpoint surface (Δ = 2.3) between two identical ν = 0.3 bodies
(γ = 3/7) pressed by P = 100 N on 65² and 129² grids (the "fft" operator,
which the coupled operator shares its layout with). Timed: the normal solve,
the uncoupled sweep (Eqs. 21–24: one corrective normal solve per Q, active
set) and the coupled sweep (one Newton increment per Q, Krylov inner
solves) over Q = k fP/N, k = 0 … N − 1. Times are medians of --repeats.

    python -m benchmarks.bench_coupled                       # writes results/bench_coupled.json
    python -m benchmarks.bench_coupled --levels 6 --ranks 1  # a quicker look
"""
from __future__ import annotations

import argparse
import statistics
import time
import warnings

from benchmarks.common import add_launch_arguments, emit, run_on_ranks, save_json, write_rows


def worker(args) -> None:
    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import ActiveSetSolver, NormalProblem
    from roughcontact.surfaces import midpoint_surface
    from roughcontact.tangential import UncoupledApproximationWarning, tangential_sweep
    from roughcontact.tangential.coupled import coupled_sweep

    warnings.simplefilter("ignore", UncoupledApproximationWarning)
    comm = MPI.COMM_WORLD
    rows: list[dict] = []
    interface = Interface(Material(20e9, 0.3), Material(20e9, 0.3))
    for level in args.levels:
        topography = midpoint_surface(level, 2.3, spacing=1e-4, rms_height=1e-5, seed=3)
        problem = NormalProblem(topography, interface, comm, operator="fft")
        times = {"normal": [], "uncoupled": [], "coupled": []}
        try:
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                with ActiveSetSolver(problem) as solver:
                    normal = solver.solve_load(100.0)
                t1 = time.perf_counter()
                tangential_sweep(problem, normal, args.friction, steps=args.steps, method="ksp", include_limit=False)
                t2 = time.perf_counter()
                coupled = coupled_sweep(problem, normal, args.friction, steps=args.steps)
                t3 = time.perf_counter()
                for key, value in zip(times, (t1 - t0, t2 - t1, t3 - t2)):
                    times[key].append(value)
        finally:
            problem.destroy()
        median = {key: statistics.median(values) for key, values in times.items()}
        emit(comm, rows, {
            "grid": list(topography.shape), "ranks": comm.Get_size(), "steps": args.steps,
            "contact_nodes": int(normal.contact.sum()), "normal_s": median["normal"],
            "uncoupled_sweep_s": median["uncoupled"], "coupled_sweep_s": median["coupled"],
            "coupled_over_uncoupled": median["coupled"] / median["uncoupled"],
            "newton_iterations": sum(s.iterations for s in coupled.states),
            "krylov_iterations": sum(s.linear_iterations for s in coupled.states)})
    write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[6, 7], help="grids of 2^level + 1 nodes a side")
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--friction", type=float, default=0.6)
    add_launch_arguments(parser, repeats=3, output="results/bench_coupled.json")
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    rows = run_on_ranks(__spec__.name, args.ranks, ["--levels", *map(str, args.levels), "--steps", str(args.steps),
                                               "--friction", str(args.friction), "--repeats", str(args.repeats)])
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
