#!/usr/bin/env python3
"""Where the primal–dual steps pay with the rotation fixed: the share of the nodes in contact at the start.

With the rotation fixed, levels of ``CGSettings.primal_dual_from`` nodes or more whose start holds
``CGSettings.primal_dual_share`` of their nodes in contact or more settle the set by the primal–dual
active set (roughcontact/normal/primal_dual.py); the others run the constrained CG alone. Each part
solves the same problems both ways, alternated in one process (one rank, the FFT operator, the
defaults otherwise): ``rule`` (the defaults) against ``cg`` (``primal_dual_from=None``), and, with
``--steps``, ``steps`` (``primal_dual_share=0``: the steps from any start on those levels).

- **sweeps**: an ensemble's task (:func:`benchmarks.common.ensemble_task`: a midpoint surface,
  Δ 2.3, 12 loads from 0.005 % to 0.5 % of E* A0 closing 2–95 % of the nodes), each load started
  from the last one's solution (warm), for each seed. Per load: the share in contact at its start
  (the last load's) and at its solution, the fine + coarse iterations and the seconds of each way
  (median of ``--repeats``), their ratio to ``cg``; per sweep the totals (sums of the loads'
  medians) and the largest force difference over the largest force;
- **fresh**: the large-grid scene's surface (Hurst 0.8, and Δ 2.5) at mean pressures of 0.003 to
  0.3 E* (E* = 1, :func:`benchmarks.common.solve_scene`), each solve from the coarse grid's start
  (set-up included, as the large-grid benchmarks time it): the share in contact, the iterations and
  seconds of each way, their ratio to ``cg``.

    python -m benchmarks.bench_settling [--parts sweeps fresh] [--levels 9 10] [--seeds 1 2]
        [--sizes 512 1024] [--pressures 0.003 0.01 0.03 0.1 0.3] [--repeats 3] [--steps]
        [--output results/bench_settling.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import alternated, ensemble_problem, save_json, scene_problem, scene_topography, solve_scene

#: the fresh part's surfaces: the large-grid scene's (Hurst 0.8) and a rougher one
SURFACES = {"hurst 0.8": {}, "Δ 2.5": {"fractal_dimension": 2.5}}


def ways(steps: bool) -> dict:
    """The settings of each way compared: the defaults' rule, the constrained CG alone, and
    (``steps``) the primal–dual steps from any start on the levels they may run on."""
    from roughcontact.normal import CGSettings

    chosen = {"rule": CGSettings(), "cg": CGSettings(primal_dual_from=None)}
    if steps:
        chosen["steps"] = CGSettings(primal_dual_share=0.0)
    return chosen


def share(problem, result) -> float:
    """The share of the problem's nodes a result holds in contact (over all ranks)."""
    return float(problem.allsum(np.count_nonzero(result.pressure > 0.0))) / problem.size


def largest_difference(forces: dict, reference: str) -> float:
    """The largest difference of any way's forces from ``reference``'s, over its largest force."""
    ref = forces[reference]
    scale = float(np.abs(ref).max())
    return max(float(np.abs(f - ref).max()) / scale for f in forces.values())


def sweeps(levels_list, seeds, repeats, settings, comm, rows) -> None:
    from roughcontact.normal import make_solver

    for levels in levels_list:
        for seed in seeds:
            problem, loads = ensemble_problem(levels, seed, comm)
            seconds = {way: np.zeros((repeats, len(loads))) for way in settings}
            iterations, shares, last = {}, {}, {}
            for repeat in range(repeats):
                for way in alternated(settings, repeat):
                    counts, closed, forces = [], [], []
                    with make_solver(problem, "cg", settings=settings[way]) as solver:
                        for k, load in enumerate(loads):
                            t0 = time.perf_counter()
                            result = solver.solve_load(load, gather=False, rotation=(0.0, 0.0))
                            seconds[way][repeat, k] = time.perf_counter() - t0
                            counts.append([result.linear_iterations, result.coarse_iterations])
                            closed.append(share(problem, result))
                            forces.append(result.pressure)      # the state's other fields let go
                    iterations[way], shares[way], last[way] = counts, closed, forces
            median = {way: np.median(seconds[way], axis=0) for way in settings}
            loads_rows = []
            for k in range(len(loads)):
                entry = {"load": k, "start_share": shares["cg"][k - 1] if k else None,
                         "share": shares["cg"][k]}
                for way in settings:
                    entry[f"{way}_iterations"] = iterations[way][k]
                    entry[f"{way}_seconds"] = float(median[way][k])
                    entry[f"{way}_ratio"] = float(median[way][k] / median["cg"][k])
                loads_rows.append(entry)
            row = {"part": "sweeps", "n": problem.topography.shape[0], "seed": seed, "loads": loads_rows,
                   **{f"{way}_seconds": float(median[way].sum()) for way in settings},
                   **{f"{way}_iterations": int(np.sum(iterations[way])) for way in settings},
                   **{f"{way}_ratio": float(median[way].sum() / median["cg"].sum()) for way in settings},
                   "force_difference": max(largest_difference({w: last[w][k] for w in settings}, "cg")
                                           for k in range(len(loads)))}
            problem.destroy()
            rows.append(row)
            print(json.dumps({key: value for key, value in row.items() if key != "loads"}), flush=True)
            for entry in loads_rows:
                print("   ", json.dumps(entry), flush=True)


def fresh(sizes, pressures, repeats, settings, comm, rows) -> None:
    for n in sizes:
        for name, shape in SURFACES.items():
            problem = scene_problem(scene_topography(n, **shape), comm)
            solve_scene(problem, pressures[0], gather=False)   # the problem's one-time set-up, untimed
            for pressure in pressures:
                seconds = {way: [] for way in settings}
                results = {}
                for repeat in range(repeats):
                    for way in alternated(settings, repeat):
                        t0 = time.perf_counter()
                        results[way] = solve_scene(problem, pressure, settings[way], gather=False)
                        seconds[way].append(time.perf_counter() - t0)
                median = {way: float(np.median(seconds[way])) for way in settings}
                row = {"part": "fresh", "n": n, "surface": name, "pressure": pressure,
                       "share": share(problem, results["cg"]),
                       **{f"{way}_iterations": [results[way].linear_iterations, results[way].coarse_iterations]
                          for way in settings},
                       **{f"{way}_seconds": median[way] for way in settings},
                       **{f"{way}_ratio": median[way] / median["cg"] for way in settings},
                       "force_difference": largest_difference({way: r.pressure for way, r in results.items()}, "cg")}
                rows.append(row)
                print(json.dumps(row), flush=True)
            problem.destroy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", nargs="+", choices=["sweeps", "fresh"], default=["sweeps", "fresh"])
    parser.add_argument("--levels", type=int, nargs="+", default=[9, 10],
                        help="the sweeps' surfaces: 2^levels + 1 nodes a side")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 1024], help="the fresh part's grids")
    parser.add_argument("--pressures", type=float, nargs="+", default=[0.003, 0.01, 0.03, 0.1, 0.3],
                        help="the fresh part's mean pressures over E*")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--steps", action="store_true",
                        help="also the primal-dual steps from any start (primal_dual_share=0)")
    parser.add_argument("--output", default="results/bench_settling.json")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    settings = ways(args.steps)
    rows: list[dict] = []
    if "sweeps" in args.parts:
        sweeps(args.levels, args.seeds, args.repeats, settings, MPI.COMM_SELF, rows)
    if "fresh" in args.parts:
        fresh(args.sizes, args.pressures, args.repeats, settings, MPI.COMM_SELF, rows)
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
