"""Command line: ``roughcontact run [STUDY.toml] [--output DIR] [--quiet] [PETSc options]``.

Also ``roughcontact analyse RESULT.nc`` (docs/analysis.md) and ``roughcontact
paper [--full] [--only FIG ...] --output DIR`` (docs/paper.md).

Run under MPI as ``mpiexec -n 4 python -m roughcontact run study.toml``: the
tasks of the study are spread over the ranks (docs/studies.md). Options that
start with a single dash (``-normal_ksp_monitor``, ``-log_view``) go to
PETSc's options database, as do all arguments after ``--``.

Exit status: 0 when every task completed, 1 when some failed (recorded in
the results), 2 for bad input, 70 when an unexpected error on some rank
aborted the job (run the same command again to resume).
"""
from __future__ import annotations

import argparse
import os
import re
import sys

# One BLAS thread per process, set before numpy loads OpenBLAS: the ranks, and the FFTs' own
# worker threads (roughcontact.operators.convolution), already use the cores, and OpenBLAS's
# spinning threads would oversubscribe them (2 ranks at 1024²: 7.3 s per solve instead of 2.4 s).
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

_PETSC_OPTION = re.compile(r"^-[A-Za-z]\w*$")


def split_petsc_args(argv: list[str]) -> tuple[list[str], list[str]]:
    """Separate PETSc options (single dash) from the program's own arguments."""
    own, petsc = [], []
    i = 0
    while i < len(argv):
        token = argv[i]
        if token == "--":
            petsc.extend(argv[i + 1:])
            break
        if _PETSC_OPTION.match(token) and token not in ("-h",):
            petsc.append(token)
            if i + 1 < len(argv) and not argv[i + 1].startswith("-"):
                petsc.append(argv[i + 1])
                i += 1
        else:
            own.append(token)
        i += 1
    return own, petsc


def misplaced_options(petsc: list[str], parser: argparse.ArgumentParser) -> dict[str, str]:
    """PETSc options that look like the program's own (``-output`` for ``--output``), with a warning each."""
    own = {option for action in _all_actions(parser) for option in action.option_strings if option.startswith("--")}
    out = {}
    for token in petsc:
        spelled = "--" + token[1:].replace("_", "-")
        if token.startswith("-") and not token.startswith("--") and spelled in own:
            out[token[1:]] = f"{token} (one dash) was passed to PETSc as an option; did you mean {spelled}?"
    return out


def _run_parser(sub) -> None:
    run = sub.add_parser("run", help="run a study (default: the built-in fractal ensemble)",
                         description="Run every task of a study not already in --output, then combine them.")
    run.add_argument("study", nargs="?", help="TOML study file (default: built-in)")
    run.add_argument("--output", default="results", help="output directory (default: results)")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    run.add_argument("--ranks-per-task", type=int, default=None, metavar="K",
                     help="ranks solving each task (default: the study's [farm] ranks_per_task, else 1)")
    run.add_argument("--retry-failed", action="store_true", help="solve again the tasks recorded as failed")
    run.add_argument("--shard", default=None, metavar="I/N",
                     help="solve only part I of N (0 <= I < N) of the tasks, split by task key (default: "
                          "SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN of SLURM_ARRAY_TASK_COUNT in a job array)")
    run.set_defaults(handler=_run)


def _run(args, comm) -> int:
    from .farm import load_study, run_study
    from .farm.leases import parse_shard

    shard = parse_shard(args.shard)
    study = load_study(args.study, comm)
    summary = run_study(study, comm, args.output, quiet=args.quiet, retry_failed=args.retry_failed,
                        ranks_per_task=args.ranks_per_task, shard=shard)
    if comm.Get_rank() == 0 and summary.solved_here:
        for option in _unused_petsc_options(args.misplaced):
            _warn(f"PETSc option -{option} was not used by any solver of this run "
                  "(misspelt, or for a solver the study does not run)")
    return summary.exit_code


def _combine_parser(sub) -> None:
    combine = sub.add_parser("combine", help="combine a study's task files into <name>.nc, solving nothing",
                             description="Combine the task files of a study under --output into <name>.nc "
                                         "(one process; no MPI launcher needed). Tasks without a file are "
                                         "left without a result (status -1); exit 1 if any.")
    combine.add_argument("study", nargs="?", help="TOML study file (default: built-in)")
    combine.add_argument("--output", default="results", help="output directory (default: results)")
    combine.set_defaults(handler=_combine)


def _combine(args, comm) -> int:
    from .farm import combine_study, load_study

    study = load_study(args.study, comm)
    return combine_study(study, args.output, comm=comm).exit_code


def _analyse_parser(sub) -> None:
    from .analysis import command as analyse

    parser = sub.add_parser("analyse", help="measure the contact domains of a study's results (docs/analysis.md)",
                            description=analyse.__doc__.split("\n")[0])
    analyse.add_arguments(parser)
    parser.set_defaults(handler=analyse.run)


def _paper_parser(sub) -> None:
    from .paper import command as paper

    parser = sub.add_parser("paper", help="reproduce the paper's figures and test its claims (docs/paper.md)",
                            description=paper.__doc__.split("\n")[0])
    paper.add_arguments(parser)
    parser.set_defaults(handler=paper.run)


#: the subcommands: each adds its parser (with ``handler(args, comm) -> exit status``) to ``sub``
SUBCOMMANDS = (_run_parser, _combine_parser, _analyse_parser, _paper_parser)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    own, petsc = split_petsc_args(argv)
    parser = argparse.ArgumentParser(prog="roughcontact", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for add in SUBCOMMANDS:
        add(sub)
    args = parser.parse_args(own)

    import petsc4py
    from mpi4py import MPI  # first: MPI with threads (the farm's executor runs a manager thread)

    petsc4py.init([sys.argv[0]] + petsc)

    from .errors import RoughContactError, StorageError
    from .farm.executor import STORAGE_CODE, abort

    comm = MPI.COMM_WORLD
    args.misplaced = misplaced_options(petsc, parser)
    if comm.Get_rank() == 0:
        for warning in args.misplaced.values():
            _warn(warning)
    try:
        return args.handler(args, comm)
    except RoughContactError as exc:      # raised on every rank by the checks
        if comm.Get_rank() == 0:
            print(f"roughcontact: error: {exc}", file=sys.stderr)
        return STORAGE_CODE if isinstance(exc, StorageError) else 2
    except BaseException:
        if comm.Get_size() == 1:
            raise
        import traceback

        abort(comm, f"roughcontact: rank {comm.Get_rank()} of {comm.Get_size()}: {traceback.format_exc()}")
        raise


def _all_actions(parser: argparse.ArgumentParser):
    for action in parser._actions:
        yield action
        for child in getattr(action, "choices", None) or {}:
            if isinstance(action.choices, dict):
                yield from _all_actions(action.choices[child])


def _unused_petsc_options(already_warned) -> list[str]:
    from petsc4py import PETSc

    options = PETSc.Options()
    return [name for name in options.getAll() if not options.used(name) and name not in already_warned]


def _warn(message: str) -> None:
    print(f"roughcontact: warning: {message}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
