#!/usr/bin/env python3
"""What a free rotation costs, and how far a state's moments move with its inner tolerance.

A study's default load control finds the rotation from zero moments (Eqs. 7-8): an inexact
Newton on (θx, θy) whose every evaluation is a load-controlled CG solve at a fixed rotation
(roughcontact/normal/rigid_motion.py), or, on levels of 256² nodes or more
(``CGSettings.rotation_from``), the primal–dual steps with the moments as constraints of each set's
solve (roughcontact/normal/primal_dual.py). Three parts, one rank, the CG on the FFT operator:

- **scenes**: the large-grid scene (0.01 E*) and near full contact (Δ = 2.5, 1 E*) of
  benchmarks.bench_products, solved with the rotation free and fixed: fine and coarse
  iterations (the free rotation's include its Hessians' Krylov iterations), the outer
  iterations (the Newton's evaluations, or the primal–dual passes that found the rotation), the
  moments left over P × extent, the rotation, seconds (median of ``--repeats``);
- **sweeps**: an ensemble's task (:func:`benchmarks.common.ensemble_task`: 12 warm-started
  loads on a midpoint surface), rotation free, for each seed: linear iterations summed over the
  loads (fine, coarse and Hessians'), outer iterations (Newton evaluations or primal–dual passes),
  the largest moments left, seconds;
- **noise**: a state solved with the rotation free; then the rotation fixed there and the state
  solved to tol t = 1e-12 … 1e-7: the change of its moments from t = 1e-12, over t × P × extent.
  The largest of these ratios sets the floor of the inner tolerance of the Newton's last states
  (``rigid_motion.CONFIRM_SHARE``): at a floor of c × load_tol the moments are off by at most
  c × ratio × load_tol.

    python -m benchmarks.bench_rotation [--parts scenes sweeps noise] [--sizes 1024 2048]
        [--levels 6 7 8] [--seeds 1 2 3] [--repeats 1] [--output results/bench_rotation.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import ensemble_task, save_json, scene_problem, scene_topography, solve_scene

#: the inner tolerances of the noise part; the first is the reference
NOISE_TOLERANCES = (1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7)


def moments_left(result, problem) -> float:
    """The largest moment a result leaves about the centroid, over P × extent (what load_tol bounds)."""
    return float(np.abs(np.asarray(result.moments)).max() / (result.load * problem.extent))


def scenes(sizes, repeats, comm, rows) -> None:
    from benchmarks.bench_products import PRESSURES, SHAPES

    for n in sizes:
        for scene in ("scene", "full"):
            problem = scene_problem(scene_topography(n, **SHAPES[scene]), comm)
            for free in (True, False):
                times = []
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    result = solve_scene(problem, PRESSURES[scene], gather=False, free_rotation=free)
                    times.append(time.perf_counter() - t0)
                row = {"part": "scenes", "scene": scene, "n": n, "rotation": "free" if free else "fixed",
                       "fine_iterations": result.linear_iterations, "coarse_iterations": result.coarse_iterations,
                       "outer_iterations": result.outer_iterations,
                       "moments_left": moments_left(result, problem) if free else None,
                       "rotation_found": list(result.rotation) if free else None,
                       "seconds": float(np.median(times))}
                rows.append(row)
                print(json.dumps(row), flush=True)
            problem.destroy()


def sweeps(levels_list, seeds, comm, rows) -> None:
    from roughcontact.normal import NormalProblem, make_solver

    for levels in levels_list:
        for seed in seeds:
            topo, rock, loads = ensemble_task(levels, seed)
            problem = NormalProblem(topo, rock, comm, operator="fft")
            iterations = outer = 0
            worst = 0.0
            t0 = time.perf_counter()
            with make_solver(problem, "cg") as solver:
                for load in loads:
                    result = solver.solve_load(load, gather=False)
                    iterations += result.linear_iterations + result.coarse_iterations
                    outer += result.outer_iterations
                    worst = max(worst, moments_left(result, problem))
            row = {"part": "sweeps", "n": topo.shape[0], "seed": seed, "loads": len(loads),
                   "linear_iterations": iterations, "outer_iterations": outer, "moments_left": worst,
                   "seconds": time.perf_counter() - t0}
            problem.destroy()
            rows.append(row)
            print(json.dumps(row), flush=True)


def noise_cases(comm):
    """(name, problem, load): the two large-grid scenes at 256² (seeds 1, 2) and four loads of the
    ensemble task at 65² and 129²."""
    from benchmarks.bench_products import PRESSURES, SHAPES
    from roughcontact.normal import NormalProblem

    for scene in ("scene", "full"):
        for seed in (1, 2):
            problem = scene_problem(scene_topography(256, seed=seed, **SHAPES[scene]), comm)
            yield f"{scene} 256² seed {seed}", problem, PRESSURES[scene] * problem.topography.nominal_area
    for levels in (6, 7):
        topo, rock, loads = ensemble_task(levels)
        for load in loads[::4]:
            yield f"ensemble task {topo.shape[0]}², {load:.3g} N", NormalProblem(topo, rock, comm, operator="fft"), load


def noise(comm, rows) -> None:
    from roughcontact.normal import CGSettings, make_solver

    for name, problem, load in noise_cases(comm):
        with make_solver(problem, "cg") as solver:
            rotation = solver.solve_load(load, gather=False).rotation
        scale = load * problem.extent
        moments = []
        for tol in NOISE_TOLERANCES:
            with make_solver(problem, "cg", settings=CGSettings(tol=tol)) as solver:
                moments.append(np.asarray(solver.solve_load(load, rotation=rotation, gather=False).moments))
        ratios = {f"{tol:g}": float(np.abs(m - moments[0]).max() / (scale * tol))
                  for tol, m in zip(NOISE_TOLERANCES[1:], moments[1:])}
        row = {"part": "noise", "case": name, "ratios": ratios, "largest": max(ratios.values())}
        problem.destroy()
        rows.append(row)
        print(json.dumps(row), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", nargs="+", choices=["scenes", "sweeps", "noise"],
                        default=["scenes", "sweeps", "noise"])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024], help="the scenes' grids")
    parser.add_argument("--levels", type=int, nargs="+", default=[6, 7, 8],
                        help="the sweeps' surfaces: 2^levels + 1 nodes a side")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--output", default="results/bench_rotation.json")
    args = parser.parse_args()

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    rows: list[dict] = []
    if "scenes" in args.parts:
        scenes(args.sizes, args.repeats, MPI.COMM_SELF, rows)
    if "sweeps" in args.parts:
        sweeps(args.levels, args.seeds, MPI.COMM_SELF, rows)
    if "noise" in args.parts:
        noise(MPI.COMM_SELF, rows)
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
