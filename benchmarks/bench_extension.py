#!/usr/bin/env python3
"""The Fourier preconditioner on the set's smooth extension: fixed-set PCG against the solver's own.

The solver's preconditioner of H_SS is M = R_S C⁻¹ R_Sᵀ (C the kernel's circulant on its
period), less the edge correction and the hole charge, which approximate the Schur term of
the exact inverse on the set, C_SS⁻¹ = B_SS − B_SO B_OO⁻¹ B_OS (B = C⁻¹, O the nodes outside S;
docs/solver-cost.md, "The ceiling of the set's Fourier preconditioner"). That Schur complement
is the least of Eᵀ B E over the extensions E = [I; T] of a field on S to the nodes outside it
(T: S → O; the least at the B-harmonic extension T = −B_OO⁻¹ B_OS). So for ANY T

    M_T = Eᵀ B E = R_S B (x on S, T x on O) + Tᵀ R_O B (the same field)

is symmetric, at least C_SS⁻¹ (M_T C_SS ≥ 1), and M_T = M at T = 0. A T close to the
harmonic extension on the smooth fields takes the top of M C_SS's spectrum: the field of one
sign over a dust of small islands, which M prices as if the ground between the islands were held
flat (the ensemble task's sets at 4–40 % in contact: Ritz values up to 10–25 with the solver's
M, C_SS⁻¹ itself 1.2–1.9).

T here is a normalised local average of the set's values: T x = G(x) / max(G(1_S), τ) on O
(G a Gaussian filter of width σ nodes over the grid, zero beyond it, or a box filter of width
nodes a side), so that next to the set the extension is the local mean of its values and far
from it the extension fades with G. One application costs the solver's one periodic product (of
a field on the whole grid) and two filters.

Rows, one per set and preconditioner: fixed-set PCG iterations to 1e-8 (b = H_SS of a random
positive vector, as benchmarks/bench_deflation.py) and the Ritz range after 40 Lanczos steps,
for ``plain`` (M, T = 0), ``solver`` (the solver's whole preconditioner on the settled set:
edge correction and hole charge), ``extension-<filter><width>-<τ>`` (M_T; ``asymmetry``: |aᵀM_T b − bᵀM_T a|
over |aᵀM_T b| for two random a, b, round-off for Eᵀ B E; ``single_ms``, for it and ``plain``:
the median milliseconds of an application in single precision, of 9) and, with ``--exact``, ``exact``
(C_SS⁻¹, the ceiling; B_OO⁻¹ by an inner CG to 1e-10). Sets: the solved contact sets of
:func:`benchmarks.common.ensemble_task`'s loads (``--loads``, the rotation fixed, each load
warm-started from the last, ``--levels``, ``--seeds``), and of the large-grid scenes
(``--scenes scene full``: 0.01 E* and Δ 2.5 at 1 E*, ``--sizes``). One rank.

Part ``sweeps`` (``--parts``): the solver with its extension (the defaults, ``extension``)
against ``CGSettings(extension_from=None)`` (``without``) along the ensemble task's 12-load
sweeps (``--sweep-levels``, ``--seeds``; each load warm-started from the last), the rotation
fixed and free (a study's default), alternated in one process, medians of ``--repeats``: fine
and coarse iterations and seconds per load and per sweep, and the largest difference of the
last load's forces over the largest force.

    python -m benchmarks.bench_extension [--parts sets sweeps] [--levels 9] [--seeds 1]
        [--loads 2 5 8 11] [--scenes scene full] [--sizes 512]
        [--extensions gauss:2:0.3 box:5:0.3] [--exact] [--sweep-levels 9] [--repeats 3]
        [--output results/bench_extension.json]
"""
from __future__ import annotations

import argparse

import numpy as np

#: the Gaussian filters' reach, in widths σ
TRUNCATE = 3.0


def extension(flexibility, filter: str, width: float, tau: float):
    """The package's M_T (:class:`~roughcontact.operators.extension.SmoothExtension`) with a box of
    ``width`` nodes a side, or with a Gaussian of σ = ``width`` nodes in its place (``filter``
    "gauss": the same M_T = Eᵀ A E with another B; one rank), the floor τ = ``tau``."""
    from scipy.ndimage import gaussian_filter

    from roughcontact.operators.extension import SmoothExtension

    class Gaussian(SmoothExtension):
        def _box(self, slab, out=None, then=None):
            filtered = gaussian_filter(slab, width, mode="constant", truncate=TRUNCATE, output=out)
            out = filtered if out is None else out
            if then is not None:                     # the passes on B's values, on all rows at once
                then(0, out.shape[0])
            return out

    kind = Gaussian if filter == "gauss" else SmoothExtension
    return kind(flexibility.preconditioner, flexibility.layout, flexibility.comm,
                width=1 if filter == "gauss" else int(width), floor=tau)


def set_rows(problem, result, base: dict, extensions, exact: bool):
    """The rows of one solved set (module docstring)."""
    from benchmarks.bench_deflation import exact_inverse, lanczos_ritz, pcg, solver_preconditioner

    flexibility = problem.flexibility
    contact = np.flatnonzero(result.contact[problem.topography.footprint])

    def apply(values):
        full = np.zeros(problem.size)
        full[contact] = values
        return flexibility.product(full)[contact]

    rhs = apply(np.abs(np.random.default_rng(0).standard_normal(contact.size)))
    ways = {"plain": lambda values: flexibility.precondition_nodes(values, contact),
            "solver": solver_preconditioner(problem, contact, result.contact)}
    # the applications timed, in single precision as the solver takes them above SINGLE_FLOOR
    singles = {"plain": lambda values: flexibility.precondition_nodes(values, contact, True)}
    for filter, width, tau in extensions:
        made = extension(flexibility, filter, width, tau)
        name = f"extension-{filter}{width:g}-{tau:g}"
        ways[name] = lambda values, made=made: made.apply(values, contact)
        singles[name] = lambda values, made=made: made.apply(values, contact, True)
    if exact:
        ways["exact"] = exact_inverse(flexibility, contact, 1e-10)[0]
    share = contact.size / problem.size
    a, b = np.random.default_rng(2).standard_normal((2, contact.size))
    for name, precondition in ways.items():
        ritz = lanczos_ritz(apply, precondition, np.random.default_rng(1).standard_normal(contact.size), 40)
        row = {**base, "share": share, "preconditioner": name, "iterations": pcg(apply, precondition, rhs),
               "ritz_min": float(ritz[0]), "ritz_max": float(ritz[-1])}
        if name in singles:
            row["single_ms"] = application_ms(singles[name], a)
        if name.startswith("extension"):             # Eᵀ B E is symmetric: aᵀ M_T b = bᵀ M_T a
            ab, ba = a @ precondition(b), b @ precondition(a)
            row["asymmetry"] = float(abs(ab - ba) / abs(ab))
        yield row


def application_ms(precondition, values: np.ndarray, repeats: int = 9) -> float:
    """The median milliseconds of one application of ``precondition`` to ``values``, after one
    untimed (which makes what it keeps for the set)."""
    import time

    precondition(values)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        precondition(values)
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def sweep_rows(levels: int, seed: int, rotation: str, repeats: int, comm):
    """The ``sweeps`` part's rows for one surface and rotation (module docstring)."""
    import time

    from benchmarks.common import alternated, ensemble_problem
    from roughcontact.normal import CGSettings, make_solver

    ways = {"extension": CGSettings(), "without": CGSettings(extension_from=None)}
    problem, loads = ensemble_problem(levels, seed, comm)
    fixed = {"rotation": (0.0, 0.0)} if rotation == "fixed" else {}
    seconds = {way: np.zeros((repeats, len(loads))) for way in ways}
    counts, last = {}, {}
    for repeat in range(repeats):
        for way in alternated(ways, repeat):
            with make_solver(problem, "cg", settings=ways[way]) as solver:
                runs = []
                for k, load in enumerate(loads):
                    start = time.perf_counter()
                    result = solver.solve_load(load, gather=False, **fixed)
                    seconds[way][repeat, k] = time.perf_counter() - start
                    runs.append([result.linear_iterations, result.coarse_iterations])
            counts[way], last[way] = runs, result.pressure
    scale = float(problem.allmax(np.abs(last["without"]).max()))
    difference = float(problem.allmax(np.abs(last["extension"] - last["without"]).max())) / scale
    problem.destroy()
    median = {way: np.median(seconds[way], axis=0) for way in ways}
    row = {"part": "sweeps", "n": 2**levels + 1, "seed": seed, "rotation": rotation, "repeats": repeats,
           "force_difference": difference}
    for way in ways:
        row[f"{way}_iterations"] = counts[way]
        row[f"{way}_seconds"] = [float(t) for t in median[way]]
        row[f"{way}_total_seconds"] = float(median[way].sum())
        row[f"{way}_fine_iterations"] = int(sum(c[0] for c in counts[way]))
    row["ratio"] = row["extension_total_seconds"] / row["without_total_seconds"]
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", type=int, nargs="*", default=[9],
                        help="the ensemble task's surfaces: 2^levels + 1 nodes a side")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--loads", type=int, nargs="+", default=[2, 5, 8, 11],
                        help="which of the task's 12 loads' solved sets")
    parser.add_argument("--scenes", nargs="*", choices=["scene", "full"], default=["scene", "full"])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512], help="the scenes' grids")
    parser.add_argument("--extensions", nargs="+", default=["gauss:2:0.3", "box:5:0.3"],
                        help="filter:width:τ of each extension: gauss (width σ in nodes) or box (width "
                             "nodes a side, odd), τ the floor of its normalisation")
    parser.add_argument("--exact", action="store_true", help="also C_SS⁻¹ itself (slow)")
    parser.add_argument("--parts", nargs="+", choices=["sets", "sweeps"], default=["sets", "sweeps"])
    parser.add_argument("--sweep-levels", type=int, nargs="+", default=[9],
                        help="the sweeps' surfaces: 2^levels + 1 nodes a side")
    parser.add_argument("--repeats", type=int, default=3, help="the sweeps' runs of each way")
    parser.add_argument("--output", default="results/bench_extension.json")
    args = parser.parse_args()
    extensions = []
    for spec in args.extensions:
        parts = spec.split(":")
        try:
            filter, width, tau = parts[0], float(parts[1]), float(parts[2])
        except (IndexError, ValueError):
            parser.error(f"--extensions takes filter:width:τ, e.g. gauss:2:0.3, not {spec!r}")
        if filter not in ("gauss", "box") or len(parts) != 3 or not (width > 0.0 and tau > 0.0):
            parser.error(f"--extensions: gauss or box, a positive width and τ, not {spec!r}")
        if filter == "box" and (width != int(width) or int(width) % 2 == 0):
            parser.error(f"--extensions: a box's width is an odd number of nodes, not {spec!r}")
        extensions.append((filter, width, tau))
    if any(not 0 <= k < 12 for k in args.loads):
        parser.error("--loads are indices of the task's 12 loads, 0-11")
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    import petsc4py

    petsc4py.init([])
    from mpi4py import MPI

    from benchmarks.bench_products import PRESSURES, SHAPES
    from benchmarks.common import emit, ensemble_problem, save_json, scene_problem, scene_topography, solve_scene
    from roughcontact.normal import make_solver

    comm = MPI.COMM_WORLD
    if comm.Get_size() != 1:
        parser.error("one rank: the extension is built on the whole grid")
    rows: list[dict] = []
    sets = "sets" in args.parts
    for levels in args.levels if sets else []:
        for seed in args.seeds:
            problem, loads = ensemble_problem(levels, seed, comm)
            with make_solver(problem, "cg") as solver:
                for k, load in enumerate(loads[:max(args.loads) + 1]):
                    result = solver.solve_load(load, rotation=(0.0, 0.0))
                    if k in args.loads:
                        base = {"part": "sets", "set": "ensemble task", "n": 2**levels + 1, "seed": seed, "load": k,
                                "fine_iterations": result.linear_iterations}
                        for row in set_rows(problem, result, base, extensions, args.exact):
                            emit(comm, rows, row)
            problem.destroy()
    for scene in args.scenes if sets else []:
        for n in args.sizes:
            problem = scene_problem(scene_topography(n, **SHAPES[scene]), comm)
            result = solve_scene(problem, PRESSURES[scene])
            base = {"part": "sets", "set": scene, "n": n, "fine_iterations": result.linear_iterations}
            for row in set_rows(problem, result, base, extensions, args.exact):
                emit(comm, rows, row)
            problem.destroy()
    for levels in args.sweep_levels if "sweeps" in args.parts else []:
        for seed in args.seeds:
            for rotation in ("fixed", "free"):
                emit(comm, rows, sweep_rows(levels, seed, rotation, args.repeats, comm))
    save_json(rows, args.output)


if __name__ == "__main__":
    main()
