#!/usr/bin/env python3
"""What a normal solve and a tangential sweep cost in FFT products, in double and mixed precision.

The targets of the constrained CG are stated in FFT-pair equivalents: the
wall time of one solve (set-up and the coarse-to-fine start included)
divided by the time of one forward and inverse real 2-D FFT of the padded
grid (``scipy.fft.rfft2`` + ``irfft2`` of (Lx, Ly) in double, the same
threads, median of 15, measured once per grid just before its solves, on
heap pages the process keeps: ``heap.hold_touched_pages``), so
the ratio depends less on how busy the machine is. For each grid and each
precision of the CG (``CGSettings.precision``), share of the
preconditioner's edge correction (``--edge-shares``, ``CGSettings.edge_share``)
and share of the gap up to which cut forces' far fields wait (``--defers``,
``CGSettings.defer``; the settings' runs alternate) the rows give that ratio,
the fine and coarse iterations, the fine grid's FFT products taken in double
and in single precision (and how many of them, held after a cut that could not
wait, skipped their inverse transforms), and the residual measured on a double
product.

Scenes: ``scene`` is the large-grid scene (Hurst 0.8, unit rms slope, mean
pressure 0.01 E*, rotation fixed; benchmarks/bench_normal_large.py);
``full`` the same with fractal dimension 2.5 at 1 E*, near full contact.
The sweep row is the 10-step tangential sweep to fP of
benchmarks/bench_tangential.py's scene (``benchmarks.common.sweep_scene``:
midpoint, Δ = 2.3, ν = 0, about 1.4 % of the nodes in contact) at 513², normal and corrective solves by the CG;
its corrective solves on the actual contact set by its explicit matrix (the default,
``restrict``: :mod:`roughcontact.tangential.contact_set`) and on the whole footprint, the two
alternated in each repeat, with their ratio.

    python -m benchmarks.bench_products [--sizes 256 512 1024 2048] [--scenes scene full]
        [--precisions double mixed] [--edge-shares 0.8] [--defers 1] [--sweep 513] [--ranks 1]
        [--warm-heap GIB] [--output results/bench_products.json]

``--warm-heap`` touches that much heap per rank before the solves and keeps it, so that a solve
does not pay the first touch of its memory: on a virtual machine that reports freed pages to its
host that first touch costs about 2 s per GiB (docs/solver-cost.md, "First touches on a virtual
machine"), 5-7 s of a 4096² solve.

Times are medians of ``--repeats`` runs (one at 2048² and above).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.common import (
    SCENE_PRESSURE,
    add_launch_arguments,
    emit,
    run_on_ranks,
    save_json,
    scene_problem,
    scene_topography,
    solve_scene,
    sweep_scene,
    worker_mpi,
    write_rows,
)

PRESSURES = {"scene": SCENE_PRESSURE, "full": 1.0}            # mean pressure / E*


class Counter:
    """Counts the FFT products of a convolution by precision (wraps its ``apply``, ``apply_at``,
    ``restricted`` and the held ones, ``held`` and ``held_at``), and those held whose inverse
    transforms were skipped (``inverse_skipped``: the products less the inverse transforms run,
    ``backward``)."""

    def __init__(self, convolution):
        self.counts = {"double": 0, "single": 0, "inverse_skipped": 0}
        convolution.apply = self._counted(convolution.apply, 1)
        convolution.apply_at = self._counted(convolution.apply_at, 2)
        convolution.restricted = self._counted(convolution.restricted, 2)
        convolution.held = self._counted(convolution.held, 1)
        convolution.held_at = self._counted(convolution.held_at, 2)
        backward = convolution.backward

        def inverse(*args, **kwargs):
            self.counts["inverse_skipped"] -= 1
            return backward(*args, **kwargs)
        convolution.backward = inverse

    def _counted(self, product, fields: int):
        """``product`` counted; its ``single`` follows ``fields`` positional arguments."""
        def counted(*args, **kwargs):
            single = args[fields] if len(args) > fields else kwargs.get("single", False)
            self.counts["single" if single else "double"] += 1
            self.counts["inverse_skipped"] += 1
            return product(*args, **kwargs)
        return counted


def fft_pair_seconds(lengths: tuple[int, int], workers: int, repeats: int = 15) -> float:
    """Median time of rfft2 + irfft2 of a random (Lx, Ly) field in double."""
    import scipy.fft as sfft

    field = np.random.default_rng(0).standard_normal(lengths)
    times = []
    for _ in range(repeats + 1):
        t0 = time.perf_counter()
        sfft.irfft2(sfft.rfft2(field, workers=workers), s=lengths, workers=workers)
        times.append(time.perf_counter() - t0)
    return float(np.median(times[1:]))


#: the surface of each scene: the large-grid one, or fractal dimension 2.5
SHAPES = {"scene": {}, "full": {"fractal_dimension": 2.5}}


def worker(args) -> None:
    MPI = worker_mpi()

    from roughcontact.normal import CGSettings
    from roughcontact.operators.convolution import SlabConvolution
    from roughcontact.operators.heap import hold_touched_pages

    comm = MPI.COMM_WORLD
    # freed pages stay with the process, so that the FFT pair's repeats reuse theirs (given back,
    # its 1 GiB blocks at 4096² took 1.18 s per pair against 0.58 s on a virtual machine that
    # reports free pages to its host); --warm-heap also has the solves' pages touched beforehand.
    # Where the allocator is left alone (not glibc, ROUGHCONTACT_HEAP=system) the rows say so
    held = hold_touched_pages(int(args.warm_heap * 2**30))
    if not held and args.warm_heap > 0:
        raise SystemExit("--warm-heap needs glibc and ROUGHCONTACT_HEAP unset")
    rows: list[dict] = []
    for scene in args.scenes:
        for n in args.sizes:
            topo = scene_topography(n, **SHAPES[scene])
            grid = SlabConvolution((n, n), comm)           # the operator's padded lengths and threads
            pair = fft_pair_seconds(grid.lengths, grid.workers)
            for precision in args.precisions:
                variants = [(share, defer) for share in args.edge_shares for defer in args.defers]
                times = {variant: [] for variant in variants}
                results, counts = {}, {}
                for _ in range(1 if n >= 2048 else args.repeats):
                    for variant in variants:                   # alternated, so all see the same machine
                        share, defer = variant
                        comm.Barrier()
                        t0 = time.perf_counter()
                        problem = scene_problem(topo, comm)
                        counter = Counter(problem.flexibility.convolution)
                        results[variant] = solve_scene(problem, PRESSURES[scene], CGSettings(
                            precision=precision, edge_share=share, defer=defer))
                        comm.Barrier()
                        times[variant].append(time.perf_counter() - t0)
                        counts[variant] = counter.counts
                        problem.destroy()
                for variant in variants:
                    seconds, result = float(np.median(times[variant])), results[variant]
                    emit(comm, rows, {
                        "kind": "normal", "scene": scene, "n": n, "ranks": comm.Get_size(), "precision": precision,
                        "edge_share": variant[0], "defer": variant[1], "seconds": seconds,
                        "all_seconds": times[variant],
                        "fft_pair_seconds": pair, "fft_pairs": seconds / pair,
                        "fine_iterations": result.linear_iterations, "coarse_iterations": result.coarse_iterations,
                        "fine_products": counts[variant], "contact_fraction": result.contact_fraction,
                        "warm_heap_gib": args.warm_heap, "pages_held": held,
                        "residual": result.residual})
    if args.sweep:
        rows.extend(sweep_rows(comm, args))
    write_rows(comm, rows, args.json)


def sweep_rows(comm, args) -> list[dict]:
    """The 10-step sweep to fP at ``args.sweep``² for each precision."""
    from roughcontact.normal import CGSettings, NormalProblem, make_solver
    from roughcontact.tangential import tangential_sweep

    n = args.sweep
    topo, interface, closure = sweep_scene(n)
    problem = NormalProblem(topo, interface, comm, operator="fft")
    with make_solver(problem, "cg") as solver:
        load = solver.solve_closure(closure).load
    rows = []
    for precision in args.precisions:
        settings = CGSettings(precision=precision)
        with make_solver(problem, "cg", settings=settings) as solver:
            normal = solver.solve_load(load)
        times, sweeps = {True: [], False: []}, {}
        for _ in range(args.repeats):
            for restrict in (True, False):
                comm.Barrier()
                t0 = time.perf_counter()
                sweeps[restrict] = tangential_sweep(problem, normal, 0.6, steps=10, method="cg",
                                                    settings=settings, restrict=restrict)
                comm.Barrier()
                times[restrict].append(time.perf_counter() - t0)
        for restrict, sweep in sweeps.items():
            correctives = [s.corrective for s in sweep.states if s.corrective is not None and s.tangential > 0]
            emit(comm, rows, {
                "kind": "sweep", "n": n, "ranks": comm.Get_size(), "precision": precision, "steps": 10,
                "restrict": restrict, "seconds": float(np.median(times[restrict])),
                "seconds_all": times[restrict],
                "restricted_over_whole": float(np.median(times[True]) / np.median(times[False])),
                "corrective_iterations": [c.linear_iterations for c in correctives],
                "corrective_choice": correctives[0].choice if correctives else "",
                "contact_fraction": normal.contact_fraction})
    problem.destroy()
    return rows


def main() -> None:
    from roughcontact.normal import CGSettings
    from roughcontact.operators.preconditioner import EDGE_SHARE

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_launch_arguments(parser, repeats=3, output="results/bench_products.json")
    parser.set_defaults(ranks=[1])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024, 2048])
    parser.add_argument("--scenes", nargs="+", choices=sorted(PRESSURES), default=["scene", "full"])
    parser.add_argument("--precisions", nargs="+", choices=["double", "mixed"], default=["double", "mixed"])
    parser.add_argument("--sweep", type=int, default=513, help="grid of the sweep row (0: none)")
    parser.add_argument("--edge-shares", type=float, nargs="+", default=[EDGE_SHARE],
                        help="CGSettings.edge_share of each normal row (0: the plain preconditioner)")
    parser.add_argument("--defers", type=float, nargs="+", default=[CGSettings().defer],
                        help="CGSettings.defer of each normal row (0: every cut takes its product)")
    parser.add_argument("--warm-heap", type=float, default=0.0, metavar="GIB",
                        help="touch and keep this many GiB of heap per rank before the solves, so that "
                             "they run on pages the system already backs (roughcontact.operators.heap."
                             "hold_touched_pages; 0: none)")
    args = parser.parse_args()
    if not args.warm_heap >= 0.0:
        parser.error(f"--warm-heap must be >= 0 GiB, got {args.warm_heap}")
    if args.worker:
        return worker(args)
    rows = run_on_ranks(__spec__.name, args.ranks, [
        "--repeats", str(args.repeats), "--sizes", *map(str, args.sizes), "--scenes", *args.scenes,
        "--precisions", *args.precisions, "--sweep", str(args.sweep), "--edge-shares", *map(str, args.edge_shares),
        "--defers", *map(str, args.defers), "--warm-heap", str(args.warm_heap)])
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
