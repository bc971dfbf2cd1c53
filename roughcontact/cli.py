"""Command line: ``roughcontact run [STUDY.toml] [--output DIR] [PETSc options]``.

Run under MPI as ``mpiexec -n 2 python -m roughcontact run``. Options that
start with a single dash (``-normal_ksp_monitor``, ``-log_view``) go to
PETSc's options database, as do all arguments after ``--``.
"""
from __future__ import annotations

import argparse
import re
import sys

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


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    own, petsc = split_petsc_args(argv)
    parser = argparse.ArgumentParser(prog="roughcontact", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a study (default: the built-in fractal load sweep)")
    run.add_argument("study", nargs="?", help="TOML study file (default: built-in)")
    run.add_argument("--output", default="results", help="output directory (default: results)")
    args = parser.parse_args(own)

    import petsc4py

    petsc4py.init([sys.argv[0]] + petsc)
    from mpi4py import MPI

    from .driver import run_normal_study
    from .errors import RoughContactError
    from .study import load_study

    comm = MPI.COMM_WORLD
    try:
        study = load_study(args.study)
        run_normal_study(study, comm, args.output)
    except RoughContactError as exc:
        if comm.Get_rank() == 0:
            print(f"roughcontact: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
