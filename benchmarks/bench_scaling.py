#!/usr/bin/env python3
"""Strong scaling of one large normal solve over ranks: the same surface, 1 to 16 ranks.

The large-grid scene (benchmarks.common.scene_surface: Hurst 0.8, unit rms
slope, mean pressure 0.01 E*, tolerance 1e-8, FFT operator, rotation fixed,
the nested start) on an n × n grid, or with ``--scenes full`` near full
contact (fractal dimension 2.5 at 1 E*, about 86 % of the nodes in contact;
benchmarks/bench_products.py's two scenes). The driver makes the surface once and
writes it with ``write_topography``; on each rank count every rank reads
only its own rows (``TopographyRows.read``) and the solve keeps its result by
rows (``gather=False``), so no rank holds the whole grid and the wall time is
the problem's set-up and solve alone.

    python -m benchmarks.bench_scaling --sizes 4096 --ranks 1 2 4 8 16 --bind-to core
        [--scenes scene full] [--repeats 1] [--output results/bench_scaling.json] [--profile DIR]

Per size and rank count: wall time (median of ``--repeats``, set-up of the
operator and every level of the start included), speed-up and parallel
efficiency against the one-rank time of the same run, fine and coarse CG
iterations, the residual, each rank's peak resident set, and the FFT
threads per rank. ``--bind-to core`` pins each rank to a core, so the FFT
runs one thread per rank and the rows measure ranks alone; without it the
ranks of a node share its cores through the FFT threads (what a user gets
by default). The force field is checked against the one-rank solve of the
same run: the sum of squared forces must agree to the solve's tolerance
(1e-8) and the contact count within one node, so a rank count that changed
the answer is reported, not timed as a success; without a one-rank row in
the run the rows are marked unchecked. The relative differences of the sum
of squares and of the largest force are recorded with each row; the largest
force is one node's and has no bound at the solve's tolerance (2048² on two
ranks: 1.4e-8, the sum of squares 8.6e-10). The total force is recorded
but checks nothing: load control makes it P on every rank count.
The rows are written after each rank count, so an interrupted run keeps
the counts it finished.

Where the time goes, per rank count (the slowest rank's seconds, wall
clocks around the package's own methods, all levels): ``nested_s`` the
coarse-to-fine start (its own products included), ``products_s`` every
FFT product of the operator and its preconditioner, ``transposes_s`` the
slab FFT's all-to-all exchanges inside them, and ``rest_s`` = seconds −
products_s (the CG's vector work, reductions and set-up). Each rank's own
seconds are kept too (``nested_s_by_rank`` ...), with the contact nodes each
rank holds (``contact_nodes_by_rank``): the slabs hold equal rows, but the
CG's work on the free set, and the transforms along y of the rows the set
occupies, follow the contact set, which on this scene gathers on a few
slabs. ``--profile DIR`` has every rank write cProfile statistics of its
solves there (an mpi4py call's waiting counts in its caller's own time).
"""
from __future__ import annotations

import argparse
import cProfile
import os
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from benchmarks.bench_products import PRESSURES, SHAPES
from benchmarks.common import (
    add_launch_arguments,
    emit,
    proc_status,
    run_on_ranks,
    save_json,
    scene_topography,
    worker_mpi,
    write_rows,
)

#: agreement of the force field's invariants with the one-rank solve. The ranks change only the
#: order of the sums, but each solve stops once its residual is below the scene's tolerance 1e-8,
#: so two rank counts may differ by up to that tolerance, not by round-off alone (4096² on a
#: 16-core machine: 1.4e-10 in the sum of squares on 2, 4 and 16 ranks, 1.8e-9 on 8)
INVARIANT_RTOL = 1e-8


@contextmanager
def clocked(methods: dict[str, tuple[type, tuple[str, ...]]]):
    """Wall seconds spent in each (class, methods) while the block runs, by name (a call inside
    another clocked call of the same name counts once)."""
    spent = {name: 0.0 for name in methods}
    depth = {name: 0 for name in methods}
    originals = {(name, attr): getattr(cls, attr) for name, (cls, attrs) in methods.items() for attr in attrs}

    def wrap(name, function):
        def timed(*args, **kwargs):
            depth[name] += 1
            t0 = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                depth[name] -= 1
                if depth[name] == 0:
                    spent[name] += time.perf_counter() - t0
        return timed

    for (name, attr), function in originals.items():
        setattr(methods[name][0], attr, wrap(name, function))
    try:
        yield spent
    finally:
        for (name, attr), function in originals.items():
            setattr(methods[name][0], attr, function)


def worker(args) -> None:
    """Under mpiexec: read one surface file by rows and solve it ``repeats`` times."""
    MPI = worker_mpi()

    import roughcontact.normal  # noqa: F401 - imports belong to the process, not to the timing
    from benchmarks.common import scene_problem, solve_scene
    from roughcontact.normal.nested import NestedStart
    from roughcontact.operators.convolution import SlabConvolution
    from roughcontact.surfaces import TopographyRows

    comm = MPI.COMM_WORLD
    rows: list[dict] = []
    topography = TopographyRows.read(args.surface, comm)
    n = topography.shape[0]
    times, result, threads = [], None, None
    phases = {"nested": (NestedStart, ("start",)), "products": (SlabConvolution, ("apply", "apply_at")),
              "transposes": (SlabConvolution, ("_exchange",))}
    profile = cProfile.Profile() if args.profile else None
    with clocked(phases) as spent:
        for _ in range(args.repeats):
            comm.Barrier()
            t0 = time.perf_counter()
            if profile is not None:
                profile.enable()
            problem = scene_problem(topography, comm)
            result = solve_scene(problem, PRESSURES[args.scene], gather=False)
            threads = problem.flexibility.convolution.workers      # the FFT threads the operator used
            problem.destroy()
            if profile is not None:
                profile.disable()
            comm.Barrier()
            times.append(time.perf_counter() - t0)
    if profile is not None:
        Path(args.profile).mkdir(parents=True, exist_ok=True)
        profile.dump_stats(Path(args.profile) / f"{args.scene}_n{n}_ranks{comm.Get_size()}_rank{comm.Get_rank()}.prof")
    per_rank = {name: comm.allgather(seconds / args.repeats) for name, seconds in spent.items()}
    split = {f"{name}_s": max(values) for name, values in per_rank.items()}     # the slowest rank's
    by_rank = {f"{name}_s_by_rank": values for name, values in per_rank.items()}
    force = np.asarray(result.force)
    # the contact set's nodes on each rank: the CG's work on the free set, and the transforms
    # along y of the rows it occupies, follow them, while the slabs hold equal rows
    contact_by_rank = comm.allgather(int(np.count_nonzero(force > 0)))
    emit(comm, rows, {
        "scene": args.scene, "n": n, "ranks": comm.Get_size(), "seconds": float(np.median(times)), "all_seconds": times,
        "repeats": args.repeats, "iterations": result.linear_iterations,
        "coarse_iterations": result.coarse_iterations, "residual": result.residual,
        "contact_fraction": result.contact_fraction,
        "force_sum": comm.allreduce(float(force.sum())),
        "force_sum_squares": comm.allreduce(float(np.dot(force.ravel(), force.ravel()))),
        "force_max": comm.allreduce(float(force.max(initial=0.0)), op=MPI.MAX),
        "contact_nodes": sum(contact_by_rank), "contact_nodes_by_rank": contact_by_rank,
        "fft_threads_per_rank": threads,
        "cores_per_rank": len(os.sched_getaffinity(0)),
        "peak_rss_bytes_per_rank": comm.allreduce(proc_status("VmHWM"), op=MPI.MAX),
        **split, "rest_s": float(np.mean(times)) - split["products_s"], **by_rank})
    write_rows(comm, rows, args.json)


def compare(rows: list[dict]) -> None:
    """Speed-up, efficiency and agreement with the one-rank solve of the same size and binding."""
    one = next((r for r in rows if r["ranks"] == 1), None)
    for row in rows:
        row["bytes_per_node_per_rank"] = row["peak_rss_bytes_per_rank"] / row["n"] ** 2
        if one is None:
            row["agrees_with_one_rank"] = None             # unchecked: no one-rank solve in this run
            continue
        row["speedup"] = one["seconds"] / row["seconds"]
        row["efficiency"] = row["speedup"] / row["ranks"]
        for key in ("force_sum_squares", "force_max"):
            row[f"{key}_relative_difference"] = abs(row[key] - one[key]) / abs(one[key])
        row["agrees_with_one_rank"] = bool(
            row["force_sum_squares_relative_difference"] <= INVARIANT_RTOL
            and abs(row["contact_nodes"] - one["contact_nodes"]) <= max(1, 1e-6 * one["contact_nodes"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[4096])
    parser.add_argument("--scenes", nargs="+", choices=sorted(PRESSURES), default=["scene"])
    parser.add_argument("--surface", help=argparse.SUPPRESS)
    parser.add_argument("--scene", default="scene", help=argparse.SUPPRESS)
    parser.add_argument("--profile", metavar="DIR",
                        help="each rank writes cProfile statistics of its solves to "
                             "DIR/<scene>_n<n>_ranks<ranks>_rank<rank>.prof")
    add_launch_arguments(parser, repeats=1, output="results/bench_scaling.json", binding=True)
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    from roughcontact.surfaces import write_topography

    report = {"benchmark": "strong scaling of one normal solve (surface and result by rows)",
              "machine": {"cpus": os.cpu_count()}, "bind_to": args.bind_to, "repeats": args.repeats,
              "invariant_rtol": INVARIANT_RTOL, "rows": []}
    profile = ["--profile", str(Path(args.profile).resolve())] if args.profile else []
    with tempfile.TemporaryDirectory() as tmp:
        for scene, n in ((scene, n) for scene in args.scenes for n in args.sizes):
            path = Path(tmp) / f"{scene}_{n}.nc"
            t0 = time.perf_counter()
            write_topography(scene_topography(n, **SHAPES[scene]), path)
            print(f"{scene} {n}²: surface made and written in {time.perf_counter() - t0:.1f} s", flush=True)
            mine: list[dict] = []
            for ranks in args.ranks:
                mine += run_on_ranks(__spec__.name, [ranks],
                                     ["--surface", str(path), "--scene", scene, "--repeats", str(args.repeats),
                                      *profile], bind_to=args.bind_to)
                compare(mine)
                report["rows"] = [r for r in report["rows"] if (r["scene"], r["n"]) != (scene, n)] + mine
                save_json(report, args.output)
            path.unlink()
    for row in report["rows"]:
        print(f"{row['scene']} {row['n']}² on {row['ranks']:2d} rank(s): {row['seconds']:7.2f} s"
              + (f", speed-up {row['speedup']:5.2f}, efficiency {row['efficiency']:.2f}" if "speedup" in row else "")
              + f", {row['iterations']} fine iterations, {row['bytes_per_node_per_rank']:.0f} B/node per rank"
              + f", {row['fft_threads_per_rank']} FFT thread(s) per rank"
              + f", contact nodes per rank {min(row['contact_nodes_by_rank'])}–{max(row['contact_nodes_by_rank'])}"
              + (f" (products {row['products_s']:.2f} s, of which transposes {row['transposes_s']:.2f} s; "
                 f"nested start {row['nested_s']:.2f} s)" if "products_s" in row else "")
              + {True: "", False: ", FORCES DIFFER FROM ONE RANK",
                 None: ", unchecked (no one-rank solve)"}[row["agrees_with_one_rank"]])


if __name__ == "__main__":
    main()
