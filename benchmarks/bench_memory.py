#!/usr/bin/env python3
"""Per-rank memory of one normal solve on 1, 2, 4 … ranks, against 1/ranks and the estimate.

The large-grid scene (benchmarks.common.scene_surface: Hurst 0.8, unit rms
slope, mean pressure 0.01 E*, rotation fixed; ``--free-rotation``: found from
zero moments, as a study's default, with the forces by the primal–dual steps, or
where they give up by the Newton, whose Hessians take explicit contact-set blocks
where the set is small), or with ``--scenes full`` near
full contact (fractal dimension 2.5 at 1 E*, 86 % of the nodes in contact;
benchmarks/bench_products.py's two scenes), the FFT operator and the
constrained CG with its defaults (mixed precision, coarse-to-fine start).
Each size runs in processes of its own; each rank makes the surface (the input a user hands to the solver, N
heights and the footprint on every rank), then the high-water mark is reset
(``/proc/self/clear_refs``) and the resident set noted; a row gives, for the
busiest rank, the peak above that point during problem set-up + solve, the
resident set left after it (the result's fields included), and
:func:`roughcontact.operators.operator_memory`'s estimate. The report fits
peak(k) = N (R + D/k) over the rank counts: R bytes per node held on every
rank, D bytes per node divided among the ranks — the figures that size a
larger run (docs/solvers.md). More ranks than cores is fine for memory.

``--by-rows``: each rank holds only its own rows of the topography
(:class:`roughcontact.surfaces.TopographyRows`, scattered from rank 0, which
makes the surface and drops it), as a run too large for the whole surface on
every rank would; a row also gives the topography's bytes on each rank and
the resident set before the solve, from which the machine's total follows.

``--sweep``: instead of one solve of a scene, an ensemble task's sweep
(:func:`benchmarks.common.ensemble_task` on 2^k + 1 nodes a side for a size
of 2^k: 12 warm-started loads from 0.005 % to 0.5 % of E* A0, 94 % of the
nodes in contact at the last at 1025², the rotation free with
``--free-rotation``, as a study's tasks), whose peak
climbs from load to load above a single solve's (the allocator keeps what
the earlier loads freed); its row gives each load's running peak too. With ``--by-rows`` the
task's surface is made on rank 0 and scattered by rows, as the farm hands a task to a group of
ranks (every rank makes it whole otherwise, outside the measured peak).

The solve keeps its result's fields on each rank's own rows (``gather=False``,
:mod:`roughcontact.normal.fields`), as a run too large to replicate N values on every rank
would; ``--gather`` measures the default, whole fields on every rank (25 B per node more).

    python -m benchmarks.bench_memory [--sizes 1024 2048] [--ranks 1 2 4] [--scenes scene full] [--gather]
        [--by-rows] [--free-rotation] [--sweep] [--output results/bench_memory.json]
"""
from __future__ import annotations

import argparse

import numpy as np

from benchmarks.bench_products import PRESSURES, SHAPES
from benchmarks.common import (
    add_launch_arguments,
    emit,
    proc_status,
    run_on_ranks,
    save_json,
    scene_problem,
    scene_topography,
    solve_scene,
    worker_mpi,
    write_rows,
)


def reset_peak() -> bool:
    """Reset VmHWM to the current resident set (Linux ≥ 4.0); False where the kernel refuses."""
    try:
        with open("/proc/self/clear_refs", "w") as handle:
            handle.write("5")
        return True
    except OSError:
        return False


def start_peak(comm) -> tuple[bool, int]:
    """(whether every rank's high-water mark was reset, this rank's resident set now): the point
    a row's peak is measured from, after the heap's retained free blocks are given back (what the
    heap keeps of freed blocks is not the solve's; collective)."""
    from mpi4py import MPI

    from roughcontact.operators.heap import release_free_blocks

    release_free_blocks()
    reset = comm.allreduce(reset_peak(), op=MPI.LAND)
    return bool(reset), proc_status("VmRSS")


def peak_since(comm, base: int, key: str = "VmHWM") -> int:
    """The busiest rank's high-water mark (or resident set, ``key`` VmRSS) above its ``base``
    (collective)."""
    from mpi4py import MPI

    return comm.allreduce(proc_status(key) - base, op=MPI.MAX)


def worker(args) -> None:
    MPI = worker_mpi()

    import roughcontact.normal  # noqa: F401 - its imports belong to the process, not to the solve
    from roughcontact.operators import operator_memory
    from roughcontact.surfaces import TopographyRows

    comm = MPI.COMM_WORLD
    rows: list[dict] = []
    for n in args.sizes:
        if args.sweep:
            emit(comm, rows, sweep_row(args, n, comm))
            continue
        if args.by_rows:
            # rank 0 makes the surface and hands each rank its rows; the whole one is then dropped
            whole = scene_topography(n, **SHAPES[args.scene]) if comm.Get_rank() == 0 else None
            topography = TopographyRows.scatter(whole, comm)
            del whole
        else:
            topography = scene_topography(n, **SHAPES[args.scene])
        held = (topography.local_heights, topography.local_footprint) if args.by_rows else \
            (topography.heights, topography.footprint)
        topography_bytes = comm.allreduce(sum(a.nbytes for a in held), op=MPI.MAX)
        reset, base = start_peak(comm)
        base_max = comm.allreduce(base, op=MPI.MAX)
        problem = scene_problem(topography, comm)
        result = solve_scene(problem, PRESSURES[args.scene], gather=args.gather, free_rotation=args.free_rotation)
        problem.destroy()
        peak, held = peak_since(comm, base), peak_since(comm, base, "VmRSS")
        nodes = n * n
        emit(comm, rows, {
            "scene": args.scene, "n": n, "ranks": comm.Get_size(), "contact_fraction": result.contact_fraction,
            "peak_bytes_per_rank": peak, "peak_per_node": peak / nodes,
            "held_after_bytes_per_rank": held, "held_after_per_node": held / nodes,
            "estimate_bytes_per_rank": operator_memory("fft", nodes, comm.Get_size()),
            "peak_reset": bool(reset), "gathered": args.gather, "by_rows": args.by_rows,
            "free_rotation": args.free_rotation,
            "topography_bytes_per_rank": topography_bytes, "resident_before_bytes_per_rank": base_max, "iterations": result.linear_iterations,
            "residual": result.residual})
    write_rows(comm, rows, args.json)


def sweep_row(args, n: int, comm) -> dict:
    """The ``--sweep`` row of size ``n`` (module docstring; collective)."""

    from benchmarks.common import ensemble_task
    from roughcontact.normal import NormalProblem, make_solver
    from roughcontact.operators import operator_memory

    topography, rock, loads = ensemble_task(int(np.log2(n)))
    if args.by_rows:
        # as the farm hands a task to a group of ranks: rank 0's surface scattered by rows
        from roughcontact.surfaces import TopographyRows

        topography = TopographyRows.scatter(topography if comm.Get_rank() == 0 else None, comm)
    reset, base = start_peak(comm)
    nodes = topography.shape[0] * topography.shape[1]
    running = []
    problem = NormalProblem(topography, rock, comm, operator="fft")
    with make_solver(problem, "cg") as solver:
        for load in loads:
            result = solver.solve_load(load, gather=args.gather,
                                       **({} if args.free_rotation else {"rotation": (0.0, 0.0)}))
            running.append(peak_since(comm, base) / nodes)
    problem.destroy()
    peak = peak_since(comm, base)
    return {
        "scene": "sweep", "n": topography.shape[0], "ranks": comm.Get_size(),
        "contact_fraction": result.contact_fraction, "peak_bytes_per_rank": peak, "peak_per_node": peak / nodes,
        "running_peak_per_node": running, "estimate_bytes_per_rank": operator_memory("fft", nodes, comm.Get_size()),
        "peak_reset": bool(reset), "gathered": args.gather, "by_rows": args.by_rows,
        "free_rotation": args.free_rotation}


def report(rows: list[dict]) -> dict:
    """Per scene and size: each rank count's peak against the one-rank peak / ranks, and the fit
    N (R + D/k)."""
    out = {}
    for scene, n in sorted({(r["scene"], r["n"]) for r in rows}):
        mine = sorted((r for r in rows if (r["scene"], r["n"]) == (scene, n)), key=lambda r: r["ranks"])
        one = next((r["peak_per_node"] for r in mine if r["ranks"] == 1), None)
        entry = {"peak_per_node": {r["ranks"]: round(r["peak_per_node"], 1) for r in mine}}
        if one is not None:
            entry["over_one_rank_share"] = {r["ranks"]: round(r["peak_per_node"] * r["ranks"] / one - 1.0, 3)
                                            for r in mine}
        if len(mine) >= 2:
            inverse = np.array([1.0 / r["ranks"] for r in mine])
            slope, intercept = np.polyfit(inverse, [r["peak_per_node"] for r in mine], 1)
            entry["replicated_per_node"] = round(float(intercept), 1)
            entry["distributed_per_node"] = round(float(slope), 1)
        out[f"{scene} {n}"] = entry
        print(scene, n, entry)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_launch_arguments(parser, repeats=1, output="results/bench_memory.json")
    parser.set_defaults(ranks=[1, 2, 4])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    parser.add_argument("--scenes", nargs="+", choices=sorted(PRESSURES), default=["scene"])
    parser.add_argument("--scene", default="scene", help=argparse.SUPPRESS)
    parser.add_argument("--gather", action="store_true",
                        help="whole result fields on every rank (the default of a solve) instead of rows")
    parser.add_argument("--by-rows", action="store_true",
                        help="each rank holds only its rows of the topography (TopographyRows, scattered "
                             "from rank 0) instead of the whole one")
    parser.add_argument("--free-rotation", action="store_true",
                        help="the rotation found from zero moments (a study's default) instead of fixed")
    parser.add_argument("--sweep", action="store_true",
                        help="an ensemble task's 12-load sweep instead of one solve of a scene")
    args = parser.parse_args()
    if args.sweep and any(n < 2 or n & (n - 1) for n in args.sizes):
        parser.error("--sweep takes sizes that are powers of two (the midpoint surface has 2^k + 1 nodes a side)")
    if args.worker:
        return worker(args)
    # one process per size and rank count: memory freed by an earlier solve stays in the process
    # (the allocator keeps it), which would hide part of the next one's peak
    extra = [flag for flag, on in (("--gather", args.gather), ("--by-rows", args.by_rows),
                                   ("--free-rotation", args.free_rotation), ("--sweep", args.sweep)) if on]
    scenes = ["sweep"] if args.sweep else args.scenes
    rows = [row for scene in scenes for n in args.sizes
            for row in run_on_ranks(__spec__.name, args.ranks, ["--sizes", str(n), "--scene", scene, *extra])]
    save_json({"rows": rows, "report": report(rows)}, args.output)


if __name__ == "__main__":
    main()
