#!/usr/bin/env python
"""The error of the uncoupled Cattaneo model against the coupled solve, charted over ν and Q/fP.

For two identical bodies (β = 0, γ = ν/(1 − ν), Eq. 4b) the uncoupled model
(Eqs. 21–24, the γ terms of Eqs. 15–16 dropped) and the coupled solve
(:mod:`roughcontact.tangential.coupled`) share the normal solution at a
given load P (load control: the pressure does not depend on ν, only the
approach does). Both sweep Q = k fP/N; at each Q/fP the relative error of
the uncoupled stick area, δx, E_f and Q_stick (Q_stick's as a fraction of
fP, since it vanishes near fP) and the distance between the two centroids
of shear G_Q (in grid spacings) are recorded, for a Hertz contact and
random-midpoint rough surfaces with Δ = 2.1, 2.3, 2.5.

    python -m tools.chart_uncoupled_error          # results/uncoupled_error.json and .png
    python -m tools.chart_uncoupled_error --level 5 --steps 5   # a quicker look
    python -m tools.chart_uncoupled_error --table roughcontact/tangential/uncoupled_error_table.py
    python -m tools.chart_uncoupled_error --from-json results/uncoupled_error.json --table -

``--table`` writes the measured bounds the datasets carry
(:mod:`roughcontact.tangential.uncoupled_error`): for each ν and Q/fP the
largest |error| over the charted surfaces, rounded up to three significant
digits; ``-`` prints it. ``--from-json`` builds chart and table from an
earlier run's rows instead of solving again.
"""
from __future__ import annotations

import argparse
import json
import math
import time
import warnings
from pathlib import Path

import numpy as np

from benchmarks.common import save_json

METRICS = {
    "stick_area": "stick area, relative error",
    "approach": "δx, relative error",
    "frictional_energy": "E_f, relative error",
    "stick_force": "Q_stick error / fP",
    "centroid": "|ΔG_Q| / s",
}
#: what the bound table holds: the metrics and the cross shear the uncoupled model drops
TABLE_METRICS = {**METRICS, "cross_traction": "max |q_⊥| / (f max p), set to 0 by the uncoupled model"}


def errors(uncoupled, coupled, spacing: float) -> dict[str, float]:
    """Errors of one uncoupled state against the coupled one at the same Q."""
    fp = coupled.friction * coupled.normal.load
    gap = math.hypot(uncoupled.centroid[0] - coupled.centroid[0], uncoupled.centroid[1] - coupled.centroid[1])
    return {
        "stick_area": uncoupled.stick_area / coupled.stick_area - 1.0 if coupled.stick_area else math.nan,
        "approach": uncoupled.tangential_approach / coupled.tangential_approach - 1.0,
        "frictional_energy": uncoupled.frictional_energy / coupled.frictional_energy - 1.0,
        "stick_force": (uncoupled.stick_force - coupled.stick_force_along) / fp,
        "centroid": gap / spacing,
    }


def surfaces(level: int):
    """(name, topography, load P, friction f) of each case, on 2^level + 1 nodes a side."""
    from roughcontact.surfaces import Topography, midpoint_surface

    n = 2**level + 1
    spacing = 50e-6 / ((n - 1) / 2.4)                 # a = 50 µm spans 2.4 a / s nodes
    x = (np.arange(n) - (n - 1) / 2) * spacing
    sphere = -(x[:, None] ** 2 + x[None, :] ** 2) / (2 * 0.01)     # Δh = −r²/(2R), R = 10 mm
    yield "hertz", Topography(sphere, spacing), None, 0.5
    for dimension in (2.1, 2.3, 2.5):
        yield (f"rough D={dimension}", midpoint_surface(level, dimension, spacing=1e-4, rms_height=1e-5, seed=3),
               100.0, 0.6)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=int, default=6, help="grid of 2^level + 1 nodes a side (6: 65²)")
    parser.add_argument("--steps", type=int, default=10, help="Q = k fP / steps")
    parser.add_argument("--nu", type=float, nargs="+", default=[0.0, 0.1, 0.2, 0.3, 0.4, 0.5])
    parser.add_argument("--output", default="results/uncoupled_error.json")
    parser.add_argument("--from-json", help="rows of an earlier run: chart and table them without solving")
    parser.add_argument("--table", help="write the bound table as a Python module to this path ('-': print it)")
    args = parser.parse_args()
    if args.from_json:
        data = json.loads(Path(args.from_json).read_text())
        emit_table(data["rows"], data["level"], data["steps"], args.table)
        return

    from mpi4py import MPI

    from roughcontact.materials import Interface, Material
    from roughcontact.normal import ActiveSetSolver, NormalProblem
    from roughcontact.tangential import UncoupledApproximationWarning, tangential_sweep
    from roughcontact.tangential.coupled import coupled_sweep

    warnings.simplefilter("ignore", UncoupledApproximationWarning)
    comm = MPI.COMM_WORLD
    rows = []
    for name, topography, load, friction in surfaces(args.level):
        for nu in args.nu:
            interface = Interface(Material(20e9, nu), Material(20e9, nu))
            problem = NormalProblem(topography, interface, comm)
            try:
                with ActiveSetSolver(problem) as solver:
                    normal = solver.solve_load(load) if load else solver.solve_closure(50e-6**2 / 0.01)
                t0 = time.perf_counter()
                uncoupled = tangential_sweep(problem, normal, friction, steps=args.steps, method="ksp",
                                             include_limit=False)
                t1 = time.perf_counter()
                coupled = coupled_sweep(problem, normal, friction, steps=args.steps)
                t2 = time.perf_counter()
            finally:
                problem.destroy()
            for u, c in zip(uncoupled.states[1:], coupled.states[1:]):
                row = {"case": name, "nu": nu, "gamma": interface.composite_poisson,
                       "Q_over_fP": round(u.load_ratio, 6), "grid": list(topography.shape),
                       "contact_nodes": int(normal.contact.sum()), **errors(u, c, topography.spacing),
                       "cross_traction": float(np.abs(c.cross_traction).max() / (friction * normal.force.max())),
                       "uncoupled_seconds": t1 - t0, "coupled_seconds": t2 - t1}
                rows.append(row)
            worst = {k: max(abs(r[k]) for r in rows[-(args.steps - 1):]) for k in METRICS}
            print(f"{name:12s} nu={nu:.2f} " + " ".join(f"{k}={v:.3g}" for k, v in worst.items())
                  + f"  ({t1 - t0:.2f} s uncoupled, {t2 - t1:.2f} s coupled)", flush=True)
    out = save_json({"metrics": METRICS, "level": args.level, "steps": args.steps, "rows": rows}, args.output)
    chart(rows, args.nu, out.with_suffix(".png"))
    emit_table(rows, args.level, args.steps, args.table)


def round_up(value: float, digits: int = 3) -> float:
    """``value`` ≥ 0 rounded up to ``digits`` significant digits (a bound must not shrink)."""
    if value == 0.0 or not math.isfinite(value):
        return value
    scale = 10.0 ** (math.floor(math.log10(value)) - digits + 1)
    return float(f"{math.ceil(value / scale - 1e-9) * scale:.{digits}g}")


def bound_table(rows: list[dict]) -> dict:
    """For each metric, ν and Q/fP: the largest |error| over the charted surfaces, rounded up."""
    nus = sorted({r["nu"] for r in rows})
    ratios = sorted({r["Q_over_fP"] for r in rows})
    gammas = [next(r["gamma"] for r in rows if r["nu"] == nu) for nu in nus]
    table = {}
    for key in TABLE_METRICS:
        table[key] = [[round_up(max((abs(r[key]) for r in rows if r["nu"] == nu and r["Q_over_fP"] == q
                                     and math.isfinite(r[key])), default=math.nan))
                       for q in ratios] for nu in nus]
    cases = sorted({r["case"] for r in rows})
    grids = sorted({"x".join(map(str, r["grid"])) for r in rows})
    return {"nu": nus, "gamma": gammas, "ratios": ratios, "table": table, "cases": cases, "grids": grids}


def emit_table(rows: list[dict], level: int, steps: int, target: str | None) -> None:
    """Write (or print, ``target`` = "-") the bound table as the module the datasets read."""
    if not target:
        return
    t = bound_table(rows)
    lines = [
        '"""Measured |error| of the uncoupled Cattaneo model against the coupled solve (β = 0).',
        "",
        "Generated by ``python -m tools.chart_uncoupled_error --table <this file>``",
        f"(level {level}: {', '.join(t['grids'])} grids, Q = k fP/{steps}; surfaces: {', '.join(t['cases'])});",
        "do not edit by hand. ERRORS[metric][i][k] is the largest |error| over those",
        "surfaces at ν = NU[i] (γ = GAMMA[i], Eq. 4b) and Q/fP = Q_OVER_FP[k], rounded up",
        "to three significant digits; the metrics are those of the chart script.",
        '"""',
        "",
        f"LEVEL = {level}",
        f"STEPS = {steps}",
        f"SURFACES = {tuple(t['cases'])!r}",
        f"NU = {tuple(t['nu'])!r}",
        f"GAMMA = {tuple(round(g, 12) for g in t['gamma'])!r}",
        f"Q_OVER_FP = {tuple(t['ratios'])!r}",
        f"METRICS = {TABLE_METRICS!r}",
        "ERRORS = {",
    ]
    for key, grid in t["table"].items():
        lines.append(f"    {key!r}: (")
        lines += [f"        {tuple(row)!r}," for row in grid]
        lines.append("    ),")
    lines.append("}")
    text = "\n".join(lines).replace("nan", "float('nan')") + "\n"
    if target == "-":
        print(text, end="")
    else:
        Path(target).write_text(text)
        print(f"wrote {target}")


def chart(rows: list[dict], nus: list[float], path: Path) -> None:
    """One panel per metric: the largest |error| over Q/fP against ν, one line per case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(1, len(METRICS), figsize=(4 * len(METRICS), 3.4), constrained_layout=True)
    for ax, (key, label) in zip(axes, METRICS.items()):
        for case in cases:
            worst = [max(abs(r[key]) for r in rows if r["case"] == case and r["nu"] == nu) for nu in nus]
            ax.plot(nus, worst, marker="o", label=case)
        ax.set_xlabel("ν (both bodies)")
        ax.set_title(label, fontsize=10)
    axes[0].set_ylabel("largest |error| over Q/fP")
    axes[0].legend(fontsize=8)
    fig.suptitle("uncoupled Cattaneo model against the coupled solve (β = 0)")
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
