#!/usr/bin/env python3
"""Speed against accuracy: wall time of every operator × method × tolerance × grid against its error.

Two scenes, against a rigid flat, E* = 1:

- **rough**: one self-affine surface (Fourier filtered, Hurst 0.8, unit rms
  slope, cut-off at L/32, non-periodic) generated on the finest grid and
  decimated to the coarser ones (the same continuous surface sampled at
  each s). Reference: the finest grid, tolerance 1e-10. At the reference's
  approach δz (displacement control, carried over to each grid in absolute
  terms) the errors are those of the load P, the contact area A_r and the
  pressure field (relative L2 against the reference pressure averaged over
  the coarse node's cell);
- **hertz**: a sphere at a/s = 8 … 64 and δ = a²/R: errors of P, of the
  contact radius √(A_r/π) and of the pressure (RMS over the contact against
  Hertz's, relative to p0), against the closed form.

Configurations: operator ``dense`` (up to 128²) and ``fft``; method ``ksp``
(active set, inner rtol 1e-3 tol) and ``cg``; tol 1e-4, 1e-6, 1e-8. Wall
time: the problem (operator) and the solve, median of ``--repeats``.

    python -m benchmarks.bench_accuracy [--rough-sizes 128 256 512] [--reference 1024] [--output results/bench_accuracy.json]

Writes JSON (rows, and per accuracy asked the cheapest configuration found)
and a PNG of time against error.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from benchmarks.common import save_json, scene_surface

TOLERANCES = (1e-4, 1e-6, 1e-8)
DENSE_LARGEST = 128 * 128


def settings(method: str, tol: float) -> dict:
    from roughcontact.normal import ActiveSetSettings, CGSettings

    if method == "cg":
        return {"settings": CGSettings(tol=tol, load_tol=tol)}
    return {"settings": ActiveSetSettings(tol=tol, load_tol=tol), "rtol": min(1e-11, 1e-3 * tol)}


def timed(topo, closure: float, operator: str, method: str, tol: float, repeats: int):
    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import NormalProblem, make_solver

    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        problem = NormalProblem(topo, Interface(Material(1.0, 0.0)), MPI.COMM_SELF, operator=operator)
        with make_solver(problem, method, **settings(method, tol)) as solver:
            result = solver.solve_closure(closure)
        problem.destroy()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), result


def configurations(nodes: int):
    for operator in ("dense", "fft"):
        if operator == "dense" and nodes > DENSE_LARGEST:
            continue
        for method in ("ksp", "cg"):
            for tol in TOLERANCES:
                yield operator, method, tol


def cell_average(field: np.ndarray, factor: int) -> np.ndarray:
    """The fine field averaged over the f × f cell centred on each decimated node (f even: the
    nodes on the cell's edges count half)."""
    from scipy.ndimage import convolve1d

    if factor == 1:
        return field
    weights = np.ones(factor + 1)
    weights[[0, -1]] = 0.5
    weights /= factor
    smooth = convolve1d(convolve1d(field, weights, axis=0, mode="constant"), weights, axis=1, mode="constant")
    return smooth[::factor, ::factor]


def rough_scene(args, rows: list[dict]) -> None:
    from roughcontact.surfaces import coarsen

    nf = args.reference
    fine = scene_surface(nf, seed=4, cutoff=1.0 / 32)
    top = float(fine.heights.max())
    # the reference approach: 0.01 E* of mean pressure on the reference grid
    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import CGSettings, NormalProblem, make_solver

    problem = NormalProblem(fine, Interface(Material(1.0, 0.0)), MPI.COMM_SELF, operator="fft")
    with make_solver(problem, "cg", settings=CGSettings(tol=1e-10, load_tol=1e-10)) as solver:
        reference = solver.solve_load(0.01 * fine.nominal_area, rotation=(0.0, 0.0))
    problem.destroy()
    absolute = reference.closure - top                       # approach measured from the fine surface's top
    print(json.dumps({"scene": "rough", "reference_n": nf, "load": reference.load,
                      "contact_fraction": reference.contact_fraction}), flush=True)
    for n in args.rough_sizes:
        factor = nf // n
        topo = coarsen(fine, factor, "decimate")
        closure = absolute + float(topo.heights.max())
        ref_pressure = cell_average(reference.pressure, factor)
        for operator, method, tol in configurations(n * n):
            seconds, result = timed(topo, closure, operator, method, tol, args.repeats)
            error_p = np.linalg.norm(result.pressure - ref_pressure) / np.linalg.norm(ref_pressure)
            row = {"scene": "rough", "n": topo.shape[0], "operator": operator, "method": method, "tol": tol,
                   "seconds": seconds, "load_error": abs(result.load / reference.load - 1.0),
                   "area_error": abs(result.contact_fraction / reference.contact_fraction - 1.0),
                   "pressure_error": float(error_p)}
            rows.append(row)
            print(json.dumps(row), flush=True)


def hertz_scene(args, rows: list[dict]) -> None:
    from roughcontact.references import hertz
    from roughcontact.surfaces import Topography

    radius = 1.0
    for a_over_s in args.hertz_sizes:
        n = int(3.3 * a_over_s) | 1
        centre = (n - 1) / 2.0
        x = np.arange(n) - centre
        r = np.hypot(x[:, None], x[None, :])
        topo = Topography(-r**2 / (2.0 * radius), 1.0)
        delta = a_over_s**2 / radius
        exact_load = hertz.load(delta, radius, 1.0)
        a = hertz.contact_radius(delta, radius)
        exact_pressure = hertz.pressure(r, delta, radius, 1.0)
        p0 = hertz.peak_pressure(delta, radius, 1.0)
        for operator, method, tol in configurations(n * n):
            seconds, result = timed(topo, delta, operator, method, tol, args.repeats)
            inside = r < a
            row = {"scene": "hertz", "n": n, "a_over_s": a_over_s, "operator": operator, "method": method,
                   "tol": tol, "seconds": seconds, "load_error": abs(result.load / exact_load - 1.0),
                   "area_error": abs(np.sqrt(result.contact_area / np.pi) / a - 1.0),
                   "pressure_error": float(np.sqrt(np.mean((result.pressure[inside] - exact_pressure[inside]) ** 2))
                                           / p0)}
            rows.append(row)
            print(json.dumps(row), flush=True)


def cheapest(rows: list[dict], scene: str, measure: str, accuracies=(0.1, 0.03, 0.01, 0.003, 0.001)) -> list:
    table = []
    for accuracy in accuracies:
        fits = [r for r in rows if r["scene"] == scene and r[measure] <= accuracy]
        best = min(fits, key=lambda r: r["seconds"]) if fits else None
        table.append({"accuracy": accuracy, "measure": measure,
                      "choice": None if best is None else {k: best[k] for k in ("n", "operator", "method", "tol",
                                                                                "seconds", measure)}})
    return table


def figure(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("rough", "area_error"), ("rough", "pressure_error"), ("hertz", "load_error"),
              ("hertz", "pressure_error")]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.8), constrained_layout=True)
    markers = {1e-4: "^", 1e-6: "s", 1e-8: "o"}
    colours = {("dense", "ksp"): "C0", ("dense", "cg"): "C1", ("fft", "ksp"): "C2", ("fft", "cg"): "C3"}
    for ax, (scene, measure) in zip(axes, panels):
        for (operator, method), colour in colours.items():
            for tol, marker in markers.items():
                pts = [(r["seconds"], max(r[measure], 1e-9)) for r in rows
                       if r["scene"] == scene and r["operator"] == operator and r["method"] == method and r["tol"] == tol]
                if pts:
                    ax.loglog(*zip(*pts), marker, color=colour, alpha=0.8,
                              label=f"{operator}/{method}" if tol == 1e-8 else None)
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel(measure.replace("_", " "))
        ax.set_title(scene, fontsize=9)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7, title="▲ 1e-4  ■ 1e-6  ● 1e-8", title_fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rough-sizes", type=int, nargs="+", default=[128, 256, 512])
    parser.add_argument("--reference", type=int, default=1024)
    parser.add_argument("--hertz-sizes", type=int, nargs="+", default=[8, 16, 32, 64])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--output", default="results/bench_accuracy.json")
    args = parser.parse_args()

    import petsc4py

    petsc4py.init([])
    rows: list[dict] = []
    hertz_scene(args, rows)
    rough_scene(args, rows)
    tables = {f"{scene}/{measure}": cheapest(rows, scene, measure)
              for scene, measure in (("rough", "area_error"), ("rough", "pressure_error"),
                                     ("hertz", "load_error"), ("hertz", "pressure_error"))}
    path = save_json({"rows": rows, "cheapest": tables}, args.output,
                     f" and {Path(args.output).with_suffix('.png')}")
    figure(rows, path.with_suffix(".png"))


if __name__ == "__main__":
    main()
