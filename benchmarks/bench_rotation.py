#!/usr/bin/env python3
"""What a free rotation costs, and how far a state's moments move with its inner tolerance.

A study's default load control finds the rotation from zero moments (Eqs. 7-8): an inexact
Newton on (θx, θy) whose every evaluation is a load-controlled CG solve at a fixed rotation
(roughcontact/normal/rigid_motion.py), or, on levels of ``CGSettings.rotation_from`` nodes or more
(every level by default), the primal–dual steps with the moments as constraints of each set's
solve (roughcontact/normal/primal_dual.py). Four parts, one rank, the CG on the FFT operator:

- **scenes**: the large-grid scene (0.01 E*) and near full contact (Δ = 2.5, 1 E*) of
  benchmarks.bench_products, solved with the rotation free and fixed: fine and coarse
  iterations (the free rotation's include its Hessians' Krylov iterations), the outer
  iterations (the Newton's evaluations, or the primal–dual passes that found the rotation), the
  moments left over P × extent, the rotation, seconds (median of ``--repeats``);
- **sweeps**: an ensemble's task (:func:`benchmarks.common.ensemble_task`: 12 warm-started
  loads on a midpoint surface), rotation free, for each seed, found with the forces on every
  level (``rotation_from=1``) and by the Newton alone (``rotation_from=None``), alternated in one
  process: linear iterations summed over the loads (fine, coarse and Hessians'), outer iterations
  (Newton evaluations or primal–dual passes), the largest moments left, seconds (median of
  ``--repeats``) and the ratio of the two;
- **few**: the few-node map, where the Newton was built for contacts of 3–12 nodes about the
  load point: midpoint surfaces of 2^levels + 1 nodes a side (Δ = 2.1, 2.3, 2.5; each seed; rock,
  ν = 0.2) at 1e-5, 5e-5 and 2e-4 E* A0, each load a fresh solve with the rotation free, by the
  primal–dual steps on every level (``rotation_from=1``) and by the Newton alone
  (``rotation_from=None``), alternated, against the paper's active set (KSP): per grid and load
  the cells, the median contact nodes, the cells whose fine level's steps gave up for the Newton
  (counted by wrapping ``settle``), the seconds of each and their ratio, the largest force difference over
  the active set's largest force, the largest moments left, the cells that failed;
- **noise**: a state solved with the rotation free; then the rotation fixed there and the state
  solved to tol t = 1e-12 … 1e-7: the change of its moments from t = 1e-12, over t × P × extent.
  The largest of these ratios sets the floor of the inner tolerance of the Newton's last states
  (``rigid_motion.CONFIRM_SHARE``): at a floor of c × load_tol the moments are off by at most
  c × ratio × load_tol.

    python -m benchmarks.bench_rotation [--parts scenes sweeps few noise] [--sizes 1024 2048]
        [--levels 6 7 8] [--seeds 1 2 3] [--repeats 1] [--output results/bench_rotation.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import (
    alternated,
    ensemble_problem,
    ensemble_task,
    save_json,
    scene_problem,
    scene_topography,
    solve_scene,
)

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


#: the two ways a free rotation is found: with the forces on every level, by the Newton alone
WAYS = {"steps": {"rotation_from": 1}, "newton": {"rotation_from": None}}


def sweeps(levels_list, seeds, repeats, comm, rows) -> None:
    from roughcontact.normal import CGSettings, make_solver

    for levels in levels_list:
        for seed in seeds:
            problem, loads = ensemble_problem(levels, seed, comm)
            times, counts = {way: [] for way in WAYS}, {}
            for repeat in range(repeats):
                for way in alternated(sorted(WAYS), repeat):
                    options = WAYS[way]
                    iterations = outer = 0
                    worst = 0.0
                    t0 = time.perf_counter()
                    with make_solver(problem, "cg", settings=CGSettings(**options)) as solver:
                        for load in loads:
                            result = solver.solve_load(load, gather=False)
                            iterations += result.linear_iterations + result.coarse_iterations
                            outer += result.outer_iterations
                            worst = max(worst, moments_left(result, problem))
                    times[way].append(time.perf_counter() - t0)
                    counts.update({f"{way}_linear_iterations": iterations, f"{way}_outer_iterations": outer,
                                   f"{way}_moments_left": worst})
            row = {"part": "sweeps", "n": problem.topography.shape[0], "seed": seed, "loads": len(loads), **counts,
                   **{f"{way}_seconds": float(np.median(times[way])) for way in WAYS},
                   "ratio": float(np.median(times["steps"]) / np.median(times["newton"]))}
            problem.destroy()
            rows.append(row)
            print(json.dumps(row), flush=True)


#: the few-node map's loads over E* A0: 3 to about 250 nodes in contact on 17² to 65²
FEW_LOADS = (1e-5, 5e-5, 2e-4)
#: the few-node map's fractal dimensions
FEW_DIMENSIONS = (2.1, 2.3, 2.5)


def few(levels_list, seeds, comm, rows) -> None:
    import roughcontact.normal.constrained_cg as constrained_cg
    from roughcontact.errors import ConvergenceError
    from roughcontact.materials import Interface, Material
    from roughcontact.normal import CGSettings, NormalProblem, make_solver
    from roughcontact.surfaces import midpoint_surface

    settle, settled = constrained_cg.settle, []

    def counted(*args, **kwargs):
        out = settle(*args, **kwargs)
        settled.append(out.converged)
        return out

    ways = {way: CGSettings(**options) for way, options in WAYS.items()}
    rock = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
    constrained_cg.settle = counted
    try:
        for levels in levels_list:
            for share in FEW_LOADS:
                cell = {way: {"seconds": 0.0, "force": 0.0, "moments": 0.0, "failed": 0} for way in ways}
                contacts, gave_up = [], 0
                for dimension in FEW_DIMENSIONS:
                    for seed in seeds:
                        topo = midpoint_surface(levels, dimension, spacing=1e-4, rms_height=1e-5, seed=seed)
                        load = share * rock.contact_modulus * topo.nominal_area
                        with NormalProblem(topo, rock, comm, operator="fft") as problem:
                            with make_solver(problem, "ksp") as solver:
                                reference = solver.solve_load(load)
                            contacts.append(int(reference.contact.sum()))
                            for way, settings in ways.items():
                                settled.clear()
                                t0 = time.perf_counter()
                                try:
                                    with make_solver(problem, "cg", settings=settings) as solver:
                                        result = solver.solve_load(load)
                                except ConvergenceError:
                                    cell[way]["failed"] += 1
                                    continue
                                finally:
                                    cell[way]["seconds"] += time.perf_counter() - t0
                                # the fine level's steps (its call is the last; a coarse level's
                                # may give up alone) gave up for the Newton
                                gave_up += bool(settled) and not settled[-1]
                                cell[way]["force"] = max(cell[way]["force"], float(
                                    np.abs(result.force - reference.force).max() / reference.force.max()))
                                cell[way]["moments"] = max(cell[way]["moments"], moments_left(result, problem))
                row = {"part": "few", "n": 2 ** levels + 1, "load_over_E_A0": share, "cells": len(contacts),
                       "contacts_median": float(np.median(contacts)), "contacts_range": [min(contacts), max(contacts)],
                       "steps_gave_up": gave_up, "ratio": cell["steps"]["seconds"] / cell["newton"]["seconds"],
                       **{f"{way}_{key}": value for way in ways for key, value in cell[way].items()}}
                rows.append(row)
                print(json.dumps(row), flush=True)
    finally:
        constrained_cg.settle = settle


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
    parser.add_argument("--parts", nargs="+", choices=["scenes", "sweeps", "few", "noise"],
                        default=["scenes", "sweeps", "noise"])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024], help="the scenes' grids")
    parser.add_argument("--levels", type=int, nargs="+", default=[6, 7, 8],
                        help="the sweeps' and the few-node map's surfaces: 2^levels + 1 nodes a side")
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
        sweeps(args.levels, args.seeds, args.repeats, MPI.COMM_SELF, rows)
    if "few" in args.parts:
        few(args.levels, args.seeds, MPI.COMM_SELF, rows)
    if "noise" in args.parts:
        noise(MPI.COMM_SELF, rows)
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
