"""``roughcontact paper [--full] [--only FIG ...] [--output DIR]``: reproduce the paper's figures and test its claims.

Runs the studies of ``studies/paper/`` (or ``studies/paper/full/`` with
``--full``) on the farm, one after the other, each into ``DIR`` as
``roughcontact run`` would (a killed run resumes task by task), printing one
line per study. Then rank 0 draws ``fig01.png`` … ``fig14.png`` (those whose
studies are all in ``DIR``), evaluates the claims (:mod:`.claims`) and writes
``claims.json``, ``claims.md`` and ``timings.json`` (seconds per study on
this run's ranks). docs/paper.md reads them.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``paper``."""
    parser.add_argument("--full", action="store_true", help="the paper's resolutions and >= 8 seeds "
                                                            "(studies/paper/full/)")
    parser.add_argument("--only", type=int, nargs="+", metavar="FIG", default=None,
                        help="draw only these figures (and run only the studies they need)")
    parser.add_argument("--output", default="paper", help="output directory (default: paper)")
    parser.add_argument("--studies", default=None, help="folder of the study files (default: the source tree's "
                                                        "studies/paper)")
    parser.add_argument("--no-run", action="store_true", help="do not solve: draw and test from what DIR holds")


def run(args, comm) -> int:
    from ..errors import RoughContactError
    from ..farm import load_study, run_study
    from .registry import FIGURES, needed, studies_folder
    from .results import study_files

    chosen = needed(args.only)
    files = study_files(studies_folder(args.full, args.studies), chosen)
    output = Path(args.output)
    rank = comm.Get_rank()
    timings = _previous_timings(output) if rank == 0 else {}
    failed = 0
    for i, study in enumerate(() if args.no_run else chosen, 1):
        definition = load_study(files[study.key])
        started = time.perf_counter()
        summary = run_study(definition, comm, output, log=lambda *a, **k: None, quiet=True)
        seconds = time.perf_counter() - started
        failed += len(summary.failed)
        if rank == 0:
            figures = " ".join(str(f) for f in study.figures)
            print(f"[{i}/{len(chosen)}] {definition.name} (Figs. {figures}): {summary.tasks} tasks, "
                  f"{summary.solved} solved, {summary.resumed} from earlier runs, {len(summary.failed)} failed; "
                  f"{seconds:.1f} s", flush=True)
            if summary.solved:     # a resumed study keeps the time of the run that solved it
                timings[definition.name] = {"tasks": summary.tasks, "solved": summary.solved,
                                            "seconds": round(seconds, 1), "ranks": comm.Get_size()}
    status = 0
    if rank == 0:      # the other ranks wait in the broadcast: a bad input here must not leave them hanging
        try:
            status = _report(args, output, files, list(args.only or FIGURES), timings)
        except RoughContactError as exc:
            print(f"roughcontact: error: {exc}", file=sys.stderr)
            status = 2
    status = comm.bcast(status, root=0)
    return status or (1 if failed else 0)


def _previous_timings(output: Path) -> dict:
    """The per-study times an earlier run recorded (a resumed study keeps the time of the run that solved it)."""
    path = output / "timings.json"
    if not path.exists():
        return {}
    try:
        return json.loads(path.read_text()).get("studies", {})
    except (OSError, ValueError) as exc:
        print(f"roughcontact: warning: {path} is unreadable ({exc}); it is rewritten with this run's times",
              file=sys.stderr)
        return {}


def _report(args, output: Path, files: dict, figures: list[int], timings: dict) -> int:
    """Figures, claims and timings from what ``output`` holds (rank 0)."""
    import warnings

    from . import claims
    from .figures import draw
    from .registry import drawable
    from .results import PaperResults

    results = PaperResults.open(output, files)
    done = set(results.root)
    started = time.perf_counter()
    drawn, skipped = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # empty slices of undefined samples in the means
        for figure in figures:
            if drawable(figure, done):
                drawn.append(draw(figure, results, output).name)
            else:
                skipped.append(figure)
        rows = claims.evaluate(results)
    print(f"  figures: {' '.join(drawn) or 'none'}" + (f"; not drawn (studies missing): {skipped}" if skipped else ""))
    (output / "claims.json").write_text(json.dumps([_clean(r.as_dict()) for r in rows], indent=1,
                                                   ensure_ascii=False))
    (output / "claims.md").write_text(claims_table(rows, "full" if args.full else "quick"))
    (output / "timings.json").write_text(json.dumps({
        "scale": "full" if args.full else "quick", "machine": platform.node(), "processor": platform.processor(),
        "studies": timings, "figures_and_claims_seconds": round(time.perf_counter() - started, 1)}, indent=1))
    verdicts = Counter(row.verdict.split(":")[0].split(" (")[0] for row in rows)
    print("  claims: " + ", ".join(f"{n} {v}" for v, n in sorted(verdicts.items()))
          + f"; wrote {output / 'claims.md'}", flush=True)
    sys.stdout.flush()
    return 0


def _clean(row: dict) -> dict:
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in row.items()}


def claims_table(rows, scale: str) -> str:
    """A Markdown table of the claim rows: number, 95 % interval over seeds, n, rule, verdict."""
    lines = [f"| claim | Fig. | quantity | condition | {scale}: mean [95 % CI] (n) | rule | verdict |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if r.n == 0:
            number = "–"
        elif r.n == 1 or not np.isfinite(r.lower):
            number = f"{r.mean:.3g} ({r.n})"
        else:
            number = f"{r.mean:.3g} [{r.lower:.3g}, {r.upper:.3g}] ({r.n})"
        lines.append(f"| {r.claim} | {r.figure} | {r.quantity or r.statement} | {r.condition} | {number} | "
                     f"{r.rule} | {r.verdict} |")
    return "\n".join(lines) + "\n"
