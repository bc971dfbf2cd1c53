#!/usr/bin/env python
"""Benchmark of the dense path: assembly time, memory, solve time, iterations.

Grids from 32² to 128² nodes of a random-midpoint-displacement surface
(Δ = 2.3) pressed to about 15 % contact, on 1 and 2 MPI ranks, with the
explicit ``dense`` operator and the active set; the paper's Gauss–Seidel
reference solver where it finishes within a budget. The assembly is
compared with filling a C-ordered array of the same size on the same rank
(``fill_c_array_s_median``; its ratio ``assembly_over_fill``). Times are
medians of --repeats runs measured in this one invocation.

    python -m benchmarks.bench_normal                         # writes results/bench_normal.json
    python -m benchmarks.bench_normal --sizes 32 64 --ranks 1 # a quicker look
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import time
from pathlib import Path

import numpy as np

from benchmarks.common import add_launch_arguments, emit, run_on_ranks, write_rows


def worker(args) -> None:
    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import ActiveSetSolver, NormalProblem
    from roughcontact.operators.dense import assemble_flexibility
    from roughcontact.operators.kernel import punch_kernel
    from roughcontact.operators.layout import NodeLayout
    from roughcontact.surfaces import Topography, midpoint_surface

    comm = MPI.COMM_WORLD
    interface = Interface(Material(20e9, 0.2), Material(20e9, 0.2))
    rows = []
    for n in args.sizes:
        levels = int(np.ceil(np.log2(n - 1))) if n > 2 else 1
        full = midpoint_surface(levels, 2.3, spacing=1e-4, rms_height=1e-5, seed=7)
        topo = Topography(full.heights[:n, :n], full.spacing)
        h = topo.heights.ravel()
        closure = float(h.max() - np.quantile(h, 0.75))
        assembly = []
        for _ in range(args.repeats):
            comm.Barrier()
            t0 = time.perf_counter()
            kernel = punch_kernel(topo.shape, topo.spacing, interface.compliance)
            mat = assemble_flexibility(kernel, NodeLayout.build(topo, comm), comm)
            comm.Barrier()
            assembly.append(time.perf_counter() - t0)
            mat.destroy()
        layout = NodeLayout.build(topo, comm)
        fills = []
        for _ in range(args.repeats):
            comm.Barrier()
            t0 = time.perf_counter()
            array = np.empty((layout.size, layout.local_size))
            array.fill(1.0)
            comm.Barrier()
            fills.append(time.perf_counter() - t0)
            del array
        problem = NormalProblem(topo, interface, comm, operator="dense")
        solves, result = [], None
        for _ in range(args.repeats):
            with ActiveSetSolver(problem) as solver:
                comm.Barrier()
                t0 = time.perf_counter()
                result = solver.solve_closure(closure)
                comm.Barrier()
                solves.append(time.perf_counter() - t0)
        row = {
            "nodes_per_side": n, "unknowns": n * n, "ranks": comm.Get_size(),
            "assembly_s_median": float(np.median(assembly)),
            "fill_c_array_s_median": float(np.median(fills)),
            "assembly_over_fill": float(np.median(assembly) / np.median(fills)),
            "matrix_bytes_per_rank": int(8 * n * n * int(np.ceil(n * n / comm.Get_size()))),
            "solve_s_median": float(np.median(solves)),
            "contact_fraction": result.contact_fraction,
            "outer_iterations": result.outer_iterations,
            "ksp_iterations": result.linear_iterations,
            "residual": result.residual,
        }
        if n * n <= args.gs_max_unknowns:
            with ActiveSetSolver(problem, "gauss-seidel") as solver:
                comm.Barrier()
                t0 = time.perf_counter()
                gs = solver.solve_closure(closure)
                comm.Barrier()
                row.update(gs_solve_s=time.perf_counter() - t0, gs_sweeps=gs.linear_iterations,
                           gs_outer_iterations=gs.outer_iterations,
                           gs_max_force_difference=float(np.abs(gs.force - result.force).max()
                                                         / np.abs(result.force).max()))
        else:
            row.update(gs_solve_s=None, gs_note=f"skipped: more than {args.gs_max_unknowns} unknowns")
        problem.destroy()
        row["peak_rss_bytes_max_rank"] = comm.allreduce(
            resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, op=MPI.MAX)
        emit(comm, rows, row)
    write_rows(comm, rows, args.json)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[32, 64, 128])
    parser.add_argument("--gs-max-unknowns", type=int, default=128 * 128,
                        help="run the Gauss-Seidel reference up to this many unknowns")
    add_launch_arguments(parser, repeats=3, output="results/bench_normal.json")
    args = parser.parse_args()
    if args.worker:
        worker(args)
        return
    rows = run_on_ranks(__spec__.name, args.ranks, ["--repeats", str(args.repeats), "--gs-max-unknowns", str(args.gs_max_unknowns),
                   "--sizes", *map(str, args.sizes)])
    report = {"benchmark": "normal contact, displacement control at ~25 % geometric overlap",
              "machine": {"cpus": os.cpu_count()}, "rows": rows}
    by = {(r["nodes_per_side"], r["ranks"]): r for r in rows}
    report["speedup_2_ranks"] = {str(n): by[(n, 1)]["solve_s_median"] / by[(n, 2)]["solve_s_median"]
                                 for n in args.sizes if (n, 1) in by and (n, 2) in by}
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(json.dumps(report, indent=1))
    figure = Path(args.output).with_suffix(".png")
    chart(rows, figure)
    print(f"wrote {args.output} and {figure}")


def chart(rows, path: Path) -> None:
    """Solve time against unknowns, Krylov and Gauss-Seidel, per rank count."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4), constrained_layout=True)
    for ranks in sorted({r["ranks"] for r in rows}):
        sel = [r for r in rows if r["ranks"] == ranks]
        ax.loglog([r["unknowns"] for r in sel], [r["solve_s_median"] for r in sel], "o-",
                  label=f"KSP CG, {ranks} rank(s)")
        gs = [r for r in sel if r.get("gs_solve_s")]
        if gs:
            ax.loglog([r["unknowns"] for r in gs], [r["gs_solve_s"] for r in gs], "s--",
                      label=f"Gauss-Seidel, {ranks} rank(s)")
    ax.set_xlabel("unknowns N (footprint nodes)")
    ax.set_ylabel("normal solve time [s] (median)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
