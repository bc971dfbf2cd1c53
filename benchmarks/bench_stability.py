#!/usr/bin/env python3
"""Stability map: where each normal method converges, and why it fails where it does not.

For every method (active set with Krylov inner solves ``ksp``, the paper's
``gauss-seidel``, the bound-constrained ``cg``) on the FFT operator, over
mean pressure σ0/E* (1e-4 to full contact), fractal dimension Δ (2.1 to 2.8,
Fourier-filtered, non-periodic, unit rms slope) and grid (64² to 1024²): a
cold load-controlled solve (rotation fixed) whose outcome is recorded as
converged, or the ConvergenceError's reason, with its iterations and wall
time. Each (method, grid) runs in its own process under a time limit
(``--limit`` seconds for the pressures of one surface; a case over it is "timeout").
Writes JSON and a heat-map PNG per method.

    python -m benchmarks.bench_stability [--sizes 64 128 256 512 1024] [--output results/bench_stability.json]

Gauss–Seidel gathers H_SS on every rank and sweeps it: it runs up to 128²;
the active set up to 512² (its explicit and matrix-free blocks make a
near-full contact at 1024² cost minutes per solve); larger grids are marked
"not run".
"""
from __future__ import annotations

import argparse
import json
import subprocess
import time
from pathlib import Path

import numpy as np

from benchmarks.common import ROOT, run_module, save_json, scene_surface

PRESSURES = (1e-4, 1e-3, 1e-2, 0.1, 0.3, 1.0)
DIMENSIONS = (2.1, 2.3, 2.5, 2.8)
METHODS = ("ksp", "gauss-seidel", "cg")
LARGEST = {"gauss-seidel": 128, "ksp": 512, "cg": 1024}


def row(args) -> None:
    """One method on one grid and surface, every pressure; JSON lines on stdout."""
    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from roughcontact.errors import ConvergenceError
    from roughcontact.materials import Interface, Material
    from roughcontact.normal import NormalProblem, make_solver

    n = args.n
    flat = Interface(Material(1.0, 0.0))
    dimension = args.dimension
    topo = scene_surface(n, fractal_dimension=dimension)
    problem = NormalProblem(topo, flat, MPI.COMM_SELF, operator="fft")
    for pressure in PRESSURES:
        t0 = time.perf_counter()
        out = {"method": args.method, "n": n, "fractal_dimension": dimension, "pressure": pressure}
        try:
            with make_solver(problem, args.method) as solver:
                result = solver.solve_load(pressure * topo.nominal_area, rotation=(0.0, 0.0))
            out.update(outcome="converged", iterations=result.linear_iterations,
                       outer=result.outer_iterations, contact_fraction=result.contact_fraction)
        except ConvergenceError as exc:
            out.update(outcome=exc.reason, message=str(exc)[:200])
        out["seconds"] = time.perf_counter() - t0
        print(json.dumps(out), flush=True)
    problem.destroy()


def heat_maps(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted({r["n"] for r in rows})
    fig, axes = plt.subplots(len(METHODS), len(sizes), figsize=(2.6 * len(sizes), 2.4 * len(METHODS)),
                             constrained_layout=True, squeeze=False)
    for i, method in enumerate(METHODS):
        for j, n in enumerate(sizes):
            ax = axes[i, j]
            grid = np.full((len(DIMENSIONS), len(PRESSURES)), np.nan)
            labels = [["" for _ in PRESSURES] for _ in DIMENSIONS]
            for r in rows:
                if r["method"] == method and r["n"] == n:
                    a, b = DIMENSIONS.index(r["fractal_dimension"]), PRESSURES.index(r["pressure"])
                    ok = r["outcome"] == "converged"
                    grid[a, b] = np.log10(r["seconds"]) if ok else np.nan
                    labels[a][b] = f"{r['seconds']:.2g}" if ok else {"not run": "–", "timeout": "T"}.get(
                        r["outcome"], "F")
            ax.imshow(grid, cmap="viridis", vmin=-2.5, vmax=2.5, aspect="auto", origin="lower")
            for a in range(len(DIMENSIONS)):
                for b in range(len(PRESSURES)):
                    ax.text(b, a, labels[a][b], ha="center", va="center", fontsize=6,
                            color="w" if np.isfinite(grid[a, b]) else "k")   # F, T, – on the white of NaN
            ax.set_xticks(range(len(PRESSURES)), [f"{p:g}" for p in PRESSURES], fontsize=6)
            ax.set_yticks(range(len(DIMENSIONS)), [f"{d:g}" for d in DIMENSIONS], fontsize=6)
            ax.set_title(f"{method}, {n}²", fontsize=8)
            if j == 0:
                ax.set_ylabel("Δ", fontsize=7)
            if i == len(METHODS) - 1:
                ax.set_xlabel("σ0 / E*", fontsize=7)
    fig.suptitle("wall time [s] of a cold solve (F: ConvergenceError, T: over the time limit, –: not run)",
                 fontsize=9)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256, 512, 1024])
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--limit", type=float, default=300.0, help="seconds for one (method, grid, Δ) row")
    parser.add_argument("--output", default="results/bench_stability.json")
    parser.add_argument("--row", nargs=3, metavar=("METHOD", "N", "DIMENSION"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.row:
        args.method, args.n, args.dimension = args.row[0], int(args.row[1]), float(args.row[2])
        return row(args)
    rows = []
    for method in args.methods:
        for n in args.sizes:
            cases = [(d, p) for d in DIMENSIONS for p in PRESSURES]
            if n > LARGEST[method]:
                rows += [{"method": method, "n": n, "fractal_dimension": d, "pressure": p, "outcome": "not run",
                          "seconds": None} for d, p in cases]
                continue
            done = []
            for dimension in DIMENSIONS:
                cmd = run_module(__spec__.name, ["--row", method, str(n), str(dimension)])
                missing = "timeout"                   # the outcome of the cases a row did not reach
                try:
                    finished = subprocess.run(cmd, capture_output=True, text=True, timeout=args.limit, cwd=ROOT)
                    stdout = finished.stdout
                    if finished.returncode != 0:
                        missing = f"crashed (rc={finished.returncode}): {finished.stderr.strip()[-200:]}"
                except subprocess.TimeoutExpired as exc:
                    stdout = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
                row_cases = [json.loads(line) for line in stdout.splitlines() if line.startswith("{")]
                seen = {r["pressure"] for r in row_cases}
                done += row_cases + [{"method": method, "n": n, "fractal_dimension": dimension, "pressure": p,
                                      "outcome": missing, "seconds": None} for p in PRESSURES if p not in seen]
            for r in done:
                print(json.dumps(r), flush=True)
            rows += done
    path = save_json(rows, args.output, f" and {Path(args.output).with_suffix('.png')}")
    heat_maps(rows, path.with_suffix(".png"))
    failures = [r for r in rows if r["outcome"] not in ("converged", "not run")]
    print(f"{len(failures)} of {sum(r['outcome'] != 'not run' for r in rows)} cases did not converge")


if __name__ == "__main__":
    main()
