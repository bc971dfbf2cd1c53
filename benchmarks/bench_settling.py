#!/usr/bin/env python3
"""Where the primal–dual steps pay on warm and fresh starts: the share of the nodes in contact at the start.

Levels of ``CGSettings.primal_dual_from`` nodes or more whose start holds ``CGSettings.primal_dual_share`` (fresh)
or ``CGSettings.primal_dual_warm_share`` (warm)
of their nodes in contact or more settle the set by the primal–dual active set first
(roughcontact/normal/primal_dual.py) wherever the rotation is fixed or imposed, and in the Newton's
first evaluation where it is found by the Newton; the others run the constrained CG alone. Each
part solves the same problems every way, alternated in one process (one rank, the FFT operator,
the defaults otherwise): ``rule`` (the defaults) against ``cg`` (``primal_dual_from=None``); with
``--steps`` also ``steps`` (``primal_dual_share=0`` and ``primal_dual_warm_share=0``: the steps from
any start on those levels; the defaults take them from any warm start already), and
with ``--unscaled`` ``unscaled`` in the closure sweeps (the constrained CG alone with
``energy_scale=False``: the forces not rescaled to the energy's minimum along them).

- **sweeps**: an ensemble's task (:func:`benchmarks.common.ensemble_task`: a midpoint surface,
  Δ 2.3, 12 loads from 0.005 % to 0.5 % of E* A0 closing 2–95 % of the nodes), each load started
  from the last one's solution (warm), for each seed; ``--sweeps``: ``load`` (load control, the
  rotation fixed), ``closure`` (displacement control at the closures an untimed load sweep of the
  constrained CG found) or ``newton`` (load control with the rotation found by the Newton alone,
  ``rotation_from=None`` in every way, so that only each load's first evaluation may settle
  first). Per load: the share in contact at its start (the last load's) and at its solution, the
  fine + coarse iterations and the seconds of each way (median of ``--repeats``, and each run's
  in the order run: with an odd count the first way goes first once more), their ratio to
  ``cg``; per sweep the totals (sums of the loads' medians) and the largest force difference over
  the largest force;
- **fresh**: the large-grid scene's surface (Hurst 0.8, and Δ 2.5) at mean pressures of 0.003 to
  0.3 E* (E* = 1, :func:`benchmarks.common.solve_scene`), each solve from the coarse grid's start
  (set-up included, as the large-grid benchmarks time it): the share in contact, the iterations and
  seconds of each way, their ratio to ``cg``.

    python -m benchmarks.bench_settling [--parts sweeps fresh] [--sweeps load closure newton]
        [--levels 9 10] [--seeds 1 2] [--sizes 512 1024] [--pressures 0.003 0.01 0.03 0.1 0.3]
        [--repeats 3] [--steps] [--unscaled] [--output results/bench_settling.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.common import alternated, ensemble_problem, save_json, scene_problem, scene_topography, solve_scene

#: the fresh part's surfaces: the large-grid scene's (Hurst 0.8) and a rougher one
SURFACES = {"hurst 0.8": {}, "Δ 2.5": {"fractal_dimension": 2.5}}


def ways(steps: bool, unscaled: bool = False, **common) -> dict:
    """The settings of each way compared: the defaults' rule, the constrained CG alone, (``steps``)
    the primal–dual steps from any start on the levels they may run on, and (``unscaled``) the
    constrained CG alone without the energy's rescaling of the forces under displacement control
    (``CGSettings.energy_scale``); ``common`` settings in every way."""
    from roughcontact.normal import CGSettings

    chosen = {"rule": CGSettings(**common), "cg": CGSettings(primal_dual_from=None, **common)}
    if steps:
        chosen["steps"] = CGSettings(primal_dual_share=0.0, primal_dual_warm_share=0.0, **common)
    if unscaled:
        chosen["unscaled"] = CGSettings(primal_dual_from=None, energy_scale=False, **common)
    return chosen


def sweep_steps(problem, loads, kind: str, settings) -> list:
    """Each step of a sweep as a call on a solver: under load control with the rotation fixed
    (``load``) or found by the Newton (``newton``), or under displacement control (``closure``) at
    the closures an untimed load sweep of the constrained CG (``settings["cg"]``) found."""
    from roughcontact.normal import solve_loads

    if kind == "load":
        return [lambda solver, load=load: solver.solve_load(load, gather=False, rotation=(0.0, 0.0))
                for load in loads]
    if kind == "newton":
        return [lambda solver, load=load: solver.solve_load(load, gather=False) for load in loads]
    closures = [r.closure for r in solve_loads(problem, loads, rotation=(0.0, 0.0), method="cg",
                                               settings=settings["cg"])]
    return [lambda solver, closure=closure: solver.solve_closure(closure, gather=False) for closure in closures]


def share(problem, result) -> float:
    """The share of the problem's nodes a result holds in contact (over all ranks)."""
    return float(problem.allsum(np.count_nonzero(result.pressure > 0.0))) / problem.size


def largest_difference(forces: dict, reference: str) -> float:
    """The largest difference of any way's forces from ``reference``'s, over its largest force."""
    ref = forces[reference]
    scale = float(np.abs(ref).max())
    return max(float(np.abs(f - ref).max()) / scale for f in forces.values())


def sweeps(kind, levels_list, seeds, repeats, settings, comm, rows) -> None:
    from roughcontact.normal import make_solver

    for levels in levels_list:
        for seed in seeds:
            problem, loads = ensemble_problem(levels, seed, comm)
            steps = sweep_steps(problem, loads, kind, settings)
            seconds = {way: np.zeros((repeats, len(loads))) for way in settings}
            iterations, shares, last = {}, {}, {}
            for repeat in range(repeats):
                for way in alternated(settings, repeat):
                    counts, closed, forces = [], [], []
                    with make_solver(problem, "cg", settings=settings[way]) as solver:
                        for k, step in enumerate(steps):
                            t0 = time.perf_counter()
                            result = step(solver)
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
                    entry[f"{way}_runs"] = [float(t) for t in seconds[way][:, k]]   # in the order run
                    entry[f"{way}_ratio"] = float(median[way][k] / median["cg"][k])
                loads_rows.append(entry)
            row = {"part": "sweeps", "sweep": kind, "n": problem.topography.shape[0], "seed": seed, "loads": loads_rows,
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
    parser.add_argument("--sweeps", nargs="+", choices=["load", "closure", "newton"], default=["load"],
                        help="the sweeps' control: load (rotation fixed), closure, or load with the "
                             "rotation found by the Newton alone")
    parser.add_argument("--levels", type=int, nargs="+", default=[9, 10],
                        help="the sweeps' surfaces: 2^levels + 1 nodes a side")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 1024], help="the fresh part's grids")
    parser.add_argument("--pressures", type=float, nargs="+", default=[0.003, 0.01, 0.03, 0.1, 0.3],
                        help="the fresh part's mean pressures over E*")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--steps", action="store_true",
                        help="also the primal-dual steps from any start (both shares 0)")
    parser.add_argument("--unscaled", action="store_true",
                        help="also the constrained CG without the energy's rescaling of the forces under "
                             "displacement control (energy_scale=False), in the closure sweeps")
    parser.add_argument("--output", default="results/bench_settling.json")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    rows: list[dict] = []
    if "sweeps" in args.parts:
        for kind in args.sweeps:
            # the rescaling acts only under displacement control: elsewhere "unscaled" is "cg"
            chosen = ways(args.steps, args.unscaled and kind == "closure",
                          **({"rotation_from": None} if kind == "newton" else {}))
            sweeps(kind, args.levels, args.seeds, args.repeats, chosen, MPI.COMM_SELF, rows)
    if "fresh" in args.parts:
        fresh(args.sizes, args.pressures, args.repeats, ways(args.steps), MPI.COMM_SELF, rows)
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
