#!/usr/bin/env python3
"""What the settling of the contact set costs near full contact: the solution's own set, held.

Near full contact the fine level settles its contact set by the primal–dual
active set (roughcontact/normal/primal_dual.py): each set is solved to THETA
of the residual it started from and then moved, and each set starts from an
exact H p. This benchmark bounds what a prediction of the set could save
(from the same start and with the same preconditioned steps, which could at
best be given S* and solve it to the tolerance).
Each surface (``full``: Δ = 2.5 at 1 E*, or ``scene``: the large-grid scene;
benchmarks/bench_products.py) is solved two ways on one rank, the rotation fixed:

- ``kept``: the solver's defaults;
- ``held``: the same nested start, but the fine level's start cut to the first
  solve's contact set S* (its forces zeroed off S*; the nodes of S* the start
  left at zero given the smallest positive double, so that they are in the set)
  and its primal–dual steps run with THETA = 0: the set is held and solved to
  the tolerance on that one set, with no move unless the tolerance shows one.
  The coarse levels run as kept.

A first, untimed solve with the defaults gives S* and makes the problem's
tables; then the two ways are solved ``--repeats`` times, alternated, each
first by turns. Per way: fine + coarse iterations, the fine level's passes
(each set, each held set gone on with, each confirmation on an exact H p: the
result's ``outer_iterations``), the median seconds and each run's, and for
``held`` the nodes where its set differs from S* and its largest force
difference over the largest force. The difference of the fine counts is what
the settling costs. ``scene`` levels whose start holds less than
``CGSettings.primal_dual_share`` (a quarter) of their nodes in contact take the
constrained CG, not the primal–dual steps: there ``held`` only cuts the start.

    python -m benchmarks.bench_held_set [--sizes 512 1024 2048] [--seeds 1] [--scenes full]
        [--repeats 1] [--output results/bench_held_set.json]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks import common
from benchmarks.bench_products import PRESSURES, SHAPES


def held_solver(problem, held: np.ndarray):
    """A ConstrainedCGSolver whose fine level holds ``held`` (a mask over the footprint's nodes, on
    one rank) from its start and solves it to the tolerance on that set (THETA = 0 on its
    primal–dual steps), with no move unless the tolerance shows one."""
    from roughcontact.normal import primal_dual
    from roughcontact.normal.constrained_cg import ConstrainedCGSolver

    if problem.comm.Get_size() != 1:
        raise ValueError("the held set is a mask over the whole footprint: one rank only")

    class HeldSet(ConstrainedCGSolver):
        def _start(self, rigid, free, loads):
            forces, motion = super()._start(rigid, free, loads)
            # the coarse levels' start, cut to the set; zero forces on it lifted to the smallest
            # positive double so that the steps take every node of it into their first set
            forces = np.where(held, np.maximum(forces, np.finfo(float).tiny), 0.0)
            return forces, motion

        def _primal_dual(self, *args, **kwargs):
            # the coarse levels are solvers of their own (ConstrainedCGSolver) and ran in _start
            theta = primal_dual.THETA
            primal_dual.THETA = 0.0
            try:
                settled = super()._primal_dual(*args, **kwargs)
            finally:
                primal_dual.THETA = theta
            if settled[0] is None:
                # the constrained CG would finish from its forces: the row would not be the bound
                raise RuntimeError(f"the held set's primal-dual steps gave up after {settled[2]} products")
            return settled

    return HeldSet(problem)


def measure(scene: str, n: int, seed: int, comm, repeats: int = 1) -> list[dict]:
    """The two rows (kept, held) of one surface, each solve's seconds the median of ``repeats``
    (the two ways alternated, each first by turns)."""
    problem = common.scene_problem(common.scene_topography(n, seed=seed, **SHAPES[scene]), comm)
    try:
        kept = common.solve_scene(problem, PRESSURES[scene])   # untimed: S*, and the problem's set-up done
        held = kept.contact[problem.topography.footprint]
        load = PRESSURES[scene] * problem.topography.nominal_area
        results, seconds = {}, {"kept": [], "held": []}
        for repeat in range(repeats):
            for way in common.alternated(("kept", "held"), repeat):
                start = time.perf_counter()
                if way == "kept":
                    results[way] = common.solve_scene(problem, PRESSURES[scene])
                else:
                    with held_solver(problem, held) as solver:
                        results[way] = solver.solve_load(load, rotation=(0.0, 0.0))
                seconds[way].append(time.perf_counter() - start)
        rows = []
        for way, result in results.items():
            row = {"scene": scene, "n": n, "seed": seed, "way": way, "fine_iterations": result.linear_iterations,
                   "coarse_iterations": result.coarse_iterations, "fine_passes": result.outer_iterations,
                   "seconds": float(np.median(seconds[way])), "runs": seconds[way],
                   "contact_fraction": float(np.mean(result.contact)), "residual": result.residual}
            if way == "held":
                row["nodes_differing"] = int(np.count_nonzero(result.contact != kept.contact))
                row["force_difference"] = float(np.abs(result.pressure - kept.pressure).max()
                                                / np.abs(kept.pressure).max())
                row["settling_costs"] = kept.linear_iterations - result.linear_iterations
            rows.append(row)
            print(" ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
                           if k != "runs"), flush=True)
    finally:
        problem.destroy()
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 2048])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--scenes", nargs="+", choices=sorted(PRESSURES), default=["full"])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--output", default="results/bench_held_set.json")
    args = parser.parse_args()
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    if comm.Get_size() != 1:
        raise SystemExit("bench_held_set runs on one rank: the held set is a mask over the whole grid")
    rows = [row for scene in args.scenes for n in args.sizes for seed in args.seeds
            for row in measure(scene, n, seed, comm, args.repeats)]
    common.save_json(rows, args.output)


if __name__ == "__main__":
    main()
