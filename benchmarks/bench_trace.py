#!/usr/bin/env python3
"""Where a solve's iterations go: the constrained CG traced step by step.

Each scene (``scene``: the large-grid scene, 0.01 E*; ``full``: near full
contact, Δ = 2.5 at 1 E*; benchmarks/bench_products.py) is solved once per
size with the solver's defaults (load control, rotation fixed, the nested
start), with the CG's logger at DEBUG on rank 0
(:mod:`roughcontact.normal.constrained_cg`). Each row is one step of one
level: its nodes, the iteration, the residual it started from, the nodes its
free set changed and holds, the returning nodes it held back (``held``), the
step α and the restarts of the directions
(``start``, ``confirmation``, ``renewal``, ``powell``, ``charge on`` / ``charge
off``: the hole charge taken or left, ``coarse space``: the balancing coarse
space made, ``plain``, ``correction dropped``).
A last row per solve (``level`` = ``solve``) gives its fine iterations and
those of the level below it (``coarse_iterations``, as the solver reports
them) and the fine level's steps: the fine count also holds the passes that
confirm convergence on an exact H p, which take no step.

    python -m benchmarks.bench_trace [--sizes 1024 2048] [--scenes scene full] [--ranks 1]
        [--output results/bench_trace.json]
"""
from __future__ import annotations

import argparse
import logging

from benchmarks import common
from benchmarks.bench_products import PRESSURES, SHAPES

LOGGER = "roughcontact.normal.constrained_cg"


class Steps(logging.Handler):
    """Keeps the ``cg_step`` record of each traced step."""

    def __init__(self):
        super().__init__(logging.DEBUG)
        self.steps: list[dict] = []

    def emit(self, record: logging.LogRecord) -> None:
        step = getattr(record, "cg_step", None)
        if step is not None:
            self.steps.append(dict(step))


def worker(args) -> None:
    MPI = common.worker_mpi()

    comm = MPI.COMM_WORLD
    logger = logging.getLogger(LOGGER)
    handler = Steps()
    if comm.Get_rank() == 0:                       # the trace is the same on every rank
        logger.addHandler(handler)
        logger.setLevel(logging.DEBUG)
    rows: list[dict] = []
    for scene in args.scenes:
        for n in args.sizes:
            problem = common.scene_problem(common.scene_topography(n, **SHAPES[scene]), comm)
            handler.steps.clear()
            result = common.solve_scene(problem, PRESSURES[scene], gather=False)
            nodes = problem.size                   # the fine level's footprint nodes
            problem.destroy()
            base = {"scene": scene, "n": n, "ranks": comm.Get_size()}
            for step in handler.steps:
                rows.append({**base, "level": "fine" if step["nodes"] == nodes else "coarse", **step})
            common.emit(comm, rows, {**base, "level": "solve", "fine_iterations": result.linear_iterations,
                              "coarse_iterations": result.coarse_iterations,
                              "fine_steps": sum(step["nodes"] == nodes for step in handler.steps),
                              "residual": result.residual})
    common.write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    common.add_launch_arguments(parser, repeats=1, output="results/bench_trace.json")
    parser.set_defaults(ranks=[1])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    parser.add_argument("--scenes", nargs="+", choices=sorted(PRESSURES), default=["scene", "full"])
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    rows = common.run_on_ranks(__spec__.name, args.ranks, ["--sizes", *map(str, args.sizes), "--scenes", *args.scenes])
    common.save_json(rows, args.output)


if __name__ == "__main__":
    main()
