#!/usr/bin/env python3
"""Large-grid normal contact: roughcontact (FFT operator, constrained CG) against Tamaas and ContactMechanics.

The scene of the targets: a self-affine, non-periodic surface (Fourier
filtered, Hurst 0.8, unit rms slope, roll-off at the box size, short cut-off
at 8 s), against a rigid flat, E* = 1, mean pressure 0.01 E*, relative
tolerance 1e-8. Each n gets one surface, saved once and read by every code,
so all three solve identical heights.

    python -m benchmarks.bench_normal_large [--sizes 128 256 512 1024 2048] [--ranks 1 2]
        [--peers-python PATH] [--peer-sizes 128 256 512 1024] [--output results/bench_normal_large.json]

roughcontact's wall time includes building the operator (the problem and
its FFT symbols) and every level of the coarse-to-fine start; medians of
``--repeats`` (one run at 2048²). Peak memory is each rank's high-water
resident set. The peers run in their own interpreter (``--peers-python``,
e.g. a virtual environment with ``pip install tamaas ContactMechanics``, or
this one with the ``bench`` extra); they are skipped with a note when absent.
Their wall times include building their model. Tolerances: Tamaas's
PolonskyKeerRey at 1e-8 of its own error measure; ContactMechanics's
constrained CG with pentol = 1e-8 of the rms height. All times from one run
of this script, so the ratios compare the same machine state.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import ROOT, SCENE_PRESSURE, proc_status, run_module, save_json, scene_surface, worker_mpi

PRESSURE = SCENE_PRESSURE          # mean pressure / E*


def make_surface(n: int, seed: int = 1) -> np.ndarray:
    return np.asarray(scene_surface(n, seed).heights)


def continuous_surfaces(sizes: list[int], seed: int = 2) -> dict[int, np.ndarray]:
    """One surface with its cut-off at L/16 (8 nodes of the coarsest grid), generated on the
    finest grid and decimated: the same continuous surface sampled at each n (n = 2^k)."""
    from roughcontact.surfaces import Topography, coarsen

    finest = max(sizes)
    s = 1.0 / finest
    fine = scene_surface(finest, seed, cutoff=1.0 / 16)
    out = {}
    for n in sizes:
        coarse = coarsen(Topography(fine.heights, s), finest // n, "decimate") if n < finest else fine
        out[n] = np.asarray(coarse.heights)
    return out


# --------------------------------------------------------------------------- roughcontact
def worker(args) -> None:
    """Under mpiexec: solve each surface file ``repeats`` times, one row per size."""
    MPI = worker_mpi()

    from benchmarks.common import emit, scene_problem, solve_scene, write_rows
    from roughcontact.surfaces import Topography

    comm = MPI.COMM_WORLD
    rows: list[dict] = []
    for path in args.surfaces:
        series = "kernels" if Path(path).name.startswith("continuous") else "timing"
        heights = np.load(path)
        n = heights.shape[0]
        topo = Topography(heights, 1.0 / n)
        times, result = [], None
        repeats = 1 if n >= 2048 or series == "kernels" else args.repeats
        for _ in range(repeats):
            comm.Barrier()
            t0 = time.perf_counter()
            problem = scene_problem(topo, comm)
            result = solve_scene(problem, PRESSURE)
            problem.destroy()
            comm.Barrier()
            times.append(time.perf_counter() - t0)
        memory = comm.allreduce(proc_status("VmHWM"), op=MPI.MAX)
        emit(comm, rows, {
            "series": series, "code": "roughcontact", "n": n, "ranks": comm.Get_size(),
            "seconds": float(np.median(times)),
            "repeats": repeats, "iterations": result.linear_iterations,
            "coarse_iterations": result.coarse_iterations, "contact_fraction": result.contact_fraction,
            "peak_rss_bytes_per_rank": memory, "bytes_per_node_per_rank": memory / (n * n),
            "residual": result.residual})
    write_rows(comm, rows, args.json)


# --------------------------------------------------------------------------- peers
def peer(args) -> None:
    """In the peers' interpreter: solve one surface file with Tamaas or ContactMechanics."""
    heights = np.load(args.surface)
    n = heights.shape[0]
    size = 1.0
    load = PRESSURE * size * size
    t0 = time.perf_counter()
    if args.peer == "tamaas":
        import tamaas as tm

        tm.set_log_level(tm.LogLevel.error)
        model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [size, size], [n, n])
        model.E, model.nu = 1.0, 0.0
        tm.ModelFactory.registerNonPeriodic(model, "dcfft")
        solver = tm.PolonskyKeerRey(model, heights, 1e-8)
        solver.setIntegralOperator("dcfft")
        solver.setMaxIterations(100000)
        solver.solve(PRESSURE)
        traction = np.asarray(model.traction)
        fraction = float(np.mean(traction > 0))
        iterations = None
        version = tm.__version__
    else:
        import ContactMechanics as cm
        from ContactMechanics import FreeFFTElasticHalfSpace
        from ContactMechanics.Optimization import constrained_conjugate_gradients
        from SurfaceTopography import Topography

        substrate = FreeFFTElasticHalfSpace((n, n), 1.0, (size, size))
        surface = Topography(heights, (size, size), periodic=False)
        result = constrained_conjugate_gradients(substrate, surface, external_force=load,
                                                 pentol=1e-8 * float(np.std(heights)), maxiter=100000)
        forces = np.asarray(result.jac)[:n, :n]
        fraction = float(np.mean(forces > 0))
        iterations = int(result.nit)
        version = cm.__version__
    print(json.dumps({"code": args.peer, "version": version, "n": n, "seconds": time.perf_counter() - t0,
                      "contact_fraction": fraction, "iterations": iterations}))


def run_peer(python: str, name: str, surface: Path, timeout: float) -> dict | None:
    cmd = run_module(__spec__.name, ["--peer", name, "--surface", str(surface)], python)
    env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "2"))
    try:
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return {"code": name, "n": int(np.load(surface).shape[0]), "seconds": None, "note": f"over {timeout:g} s"}
    if run.returncode != 0:
        return {"code": name, "note": run.stderr.strip().splitlines()[-1] if run.stderr.strip() else "failed"}
    return json.loads(run.stdout.strip().splitlines()[-1])


def peers_available(python: str) -> list[str]:
    found = []
    for name, module in (("tamaas", "tamaas"), ("contactmechanics", "ContactMechanics")):
        if subprocess.run([python, "-c", f"import {module}"], capture_output=True).returncode == 0:
            found.append(name)
    return found


# --------------------------------------------------------------------------- report
def growth(rows: list[dict], ranks: int) -> float | None:
    points = sorted((r["n"] ** 2, r["seconds"]) for r in rows
                    if r["code"] == "roughcontact" and r["ranks"] == ranks and r["series"] == "timing")
    if len(points) < 2:
        return None
    nodes, seconds = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(nodes, seconds, 1)[0])


def figure(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    series = sorted({(r["code"], r.get("ranks", 1)) for r in rows if r.get("seconds")})
    for code, ranks in series:
        label = f"{code} ({ranks} rank{'s' if ranks > 1 else ''})" if code == "roughcontact" else code
        timing = sorted((r["n"], r["seconds"]) for r in rows if r["series"] == "timing" and r["code"] == code
                        and r.get("ranks", 1) == ranks and r.get("seconds"))
        left.loglog([p[0] ** 2 for p in timing], [p[1] for p in timing], "o-", label=label)
        if code != "roughcontact" or ranks == 1:
            kernels = sorted((r["n"], r["contact_fraction"]) for r in rows if r["series"] == "kernels"
                             and r["code"] == code and r.get("contact_fraction"))
            right.semilogx([p[0] for p in kernels], [p[1] for p in kernels], "o-", label=label.split(" (")[0])
    targets = {512: 1.5, 1024: 5.0, 2048: 25.0}
    left.loglog([n * n for n in targets], list(targets.values()), "k_", markersize=14, label="target")
    left.set_xlabel("nodes N")
    left.set_ylabel("wall time of one normal solve [s]")
    left.legend(fontsize=8)
    left.grid(alpha=0.3, which="both")
    right.set_xlabel("nodes per side n (one continuous surface, decimated)")
    right.set_ylabel("contact fraction A_r / A_0 at 0.01 E*")
    right.legend(fontsize=8)
    right.grid(alpha=0.3)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    from benchmarks.common import add_launch_arguments, run_on_ranks

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_launch_arguments(parser, repeats=3, output="results/bench_normal_large.json")
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512, 1024, 2048])
    parser.add_argument("--surfaces", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("--peers-python", default=sys.executable)
    parser.add_argument("--peer-sizes", type=int, nargs="+", default=[128, 256, 512, 1024])
    parser.add_argument("--peer-timeout", type=float, default=900.0)
    parser.add_argument("--kernel-sizes", type=int, nargs="+", default=[128, 256, 512, 1024],
                        help="the same continuous surface at these n (powers of 2), every code")
    parser.add_argument("--peer", choices=["tamaas", "contactmechanics"], help=argparse.SUPPRESS)
    parser.add_argument("--surface", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.peer:
        return peer(args)
    if args.worker:
        return worker(args)

    output = Path(args.output)
    output.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        surfaces, continuous = {}, {}
        for n in args.sizes:
            surfaces[n] = Path(tmp) / f"surface-{n}.npy"
            np.save(surfaces[n], make_surface(n))
        for n, heights in continuous_surfaces(args.kernel_sizes).items():
            continuous[n] = Path(tmp) / f"continuous-{n}.npy"
            np.save(continuous[n], heights)
        rows = run_on_ranks(__spec__.name, args.ranks, ["--repeats", str(args.repeats), "--surfaces",
                                                   *[str(surfaces[n]) for n in args.sizes],
                                                   *[str(continuous[n]) for n in args.kernel_sizes]])
        names = peers_available(args.peers_python)
        notes = [] if names else [f"Tamaas and ContactMechanics are not importable from {args.peers_python}: "
                                  "peers skipped (pip install tamaas ContactMechanics, then --peers-python)"]
        for name in names:
            for series, files, sizes in (("timing", surfaces, args.peer_sizes),
                                         ("kernels", continuous, args.kernel_sizes)):
                for n in sizes:
                    if n in files:
                        row = {"series": series, **run_peer(args.peers_python, name, files[n], args.peer_timeout)}
                        print(json.dumps(row), flush=True)
                        rows.append(row)
    ours = {(r["n"], r["ranks"]): r for r in rows if r["code"] == "roughcontact" and r["series"] == "timing"}
    mine = {r["n"]: r["contact_fraction"] for r in rows if r["code"] == "roughcontact" and r["series"] == "kernels"}
    for row in rows:
        if row["series"] == "kernels" and row["code"] != "roughcontact" and row.get("contact_fraction"):
            row["contact_fraction_over_roughcontact"] = row["contact_fraction"] / mine[row["n"]]
        if row["series"] == "timing" and row["code"] != "roughcontact" and row.get("seconds"):
            for ranks in args.ranks:
                if (row["n"], ranks) in ours:
                    row[f"ratio_to_roughcontact_{ranks}_ranks"] = row["seconds"] / ours[(row["n"], ranks)]["seconds"]
    summary = {"rows": rows, "notes": notes,
               "growth_exponent": {str(r): growth(rows, r) for r in args.ranks},
               "scene": {"hurst": 0.8, "rms_slope": 1.0, "mean_pressure_over_Estar": PRESSURE, "tolerance": 1e-8}}
    save_json(summary, output, f" and {output.with_suffix('.png')}")
    figure(rows, output.with_suffix(".png"))
    print(json.dumps(summary["growth_exponent"]), *notes, sep="\n")


if __name__ == "__main__":
    main()
