"""Run a study on a communicator: checks, the farm, the combined dataset, statistics and the figure.

:func:`run_study` is what ``roughcontact run`` does. Order matters: the
output directory is checked writable and claimed, finished tasks are found
(resume), the memory of the largest operator is checked and the size of the
results printed, all before the first solve; each task is on disk as soon as
it finishes; the combined dataset is written last.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .. import __version__
from .combine import combine, write_combined
from .definition import Study
from .executor import group_count, on_root, run_farm
from .guards import check_operator_memory, oversubscription, storage_estimate, task_size
from .progress import Progress
from .records import encode, task_groups
from .store import TaskStore
from .task import solve_task


@dataclass
class RunSummary:
    """What a run did, on every rank."""

    name: str
    tasks: int
    resumed: int
    solved: int
    failed: dict[int, str] = field(default_factory=dict)
    warned: int = 0
    paths: dict[str, Path] = field(default_factory=dict)
    elapsed: float = 0.0
    solved_here: int = 0

    @property
    def exit_code(self) -> int:
        """0 when every task completed, 1 when some failed (their results are recorded)."""
        return 1 if self.failed else 0


def run_study(study: Study, comm, output: str | Path, log: Callable = print, quiet: bool = False,
              retry_failed: bool = False, ranks_per_task: int | None = None) -> RunSummary:
    """Solve every task of ``study`` not already on disk under ``output``, then combine them.

    Collective over ``comm``. Writes ``<output>/<name>.tasks/task-*.nc`` as
    tasks finish, then ``<output>/<name>.nc`` and, when a load sweep has
    completed, ``<output>/<name>_area_vs_load.png`` (Fig. 5a, with
    confidence bands over seeds). ``ranks_per_task`` overrides the study's.
    ``retry_failed`` solves again the tasks recorded as failed.
    """
    from petsc4py import PETSc  # noqa: F401  PETSc starts collectively over all ranks on first import:
    #                             here, before the farm sends ranks their separate ways
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    t0 = time.perf_counter()
    rank = comm.Get_rank()
    say = log if rank == 0 else (lambda *a, **k: None)
    k = study.ranks_per_task if ranks_per_task is None else ranks_per_task
    tasks = study.tasks()
    store = TaskStore(output, study.name)
    finished = on_root(comm, _resume, store, study, retry_failed)
    pending = [t for t in tasks if t.index not in finished]
    count = group_count(comm.Get_size(), k)      # refuses a k that does not divide the ranks
    grid, footprint = on_root(comm, _sizes, pending)
    if pending:
        check_operator_memory(study, footprint, comm, k)
        if pending[0].surface["generator"] != "file":     # measured surfaces: read whole by task_size
            on_root(comm, _build_surface, pending[0])
    crowded = oversubscription(comm)
    if crowded and rank == 0:
        print(f"roughcontact: warning: {crowded}", file=sys.stderr)
    say(f"{study.name}: {len(tasks)} task(s), {len(finished)} already done, {comm.Get_size()} rank(s) in "
        f"{count} group(s) of {k}, operator {study.normal.operator}, method {study.normal.method}")
    if pending:
        say(f"  storage: {storage_estimate(study, grid)}")
    on_root(comm, store.claim, study)
    progress = Progress(study.name, len(tasks), len(finished), enabled=not quiet and rank == 0)
    solved_here = [0]

    def work(task, group):
        outcome = solve_task(task, group)
        solved_here[0] += 1
        return (outcome.error, encode(task_groups(outcome))) if group.Get_rank() == 0 else None

    def deliver(task, payload):
        error, data = payload
        progress.task_done(bool(error), store.write(task.index, data))

    run_farm(pending, comm, k, work, deliver)
    progress.close()
    attrs = _provenance(study, comm, k, started, _petsc_options())
    paths = on_root(comm, _finish, study, store, attrs, tasks)
    solved = comm.bcast(progress.solved, root=0)
    summary = RunSummary(name=study.name, tasks=len(tasks), resumed=len(finished), solved=solved,
                         failed=paths.pop("failed"), warned=paths.pop("warned"), paths=paths, elapsed=time.perf_counter() - t0,
                         solved_here=solved_here[0])
    say(_closing(summary, progress.written))
    return summary



def _build_surface(task) -> None:
    """Build a task's surface once and drop it: bad generator arguments (a generated surface is
    only sized, not built, before this) are an InputError before any solve."""
    task.topography()


def _resume(store: TaskStore, study: Study, retry_failed: bool) -> set[int]:
    """Check the output is writable and holds no other study; the tasks already done."""
    store.check_writable()
    store.check_owner(study)
    return store.finished(retry_failed)


def _sizes(tasks: list) -> tuple[int, int]:
    """The largest grid and footprint (nodes) over ``tasks``."""
    sizes = [task_size(t) for t in tasks] or [(0, 0)]
    return max(g for g, _ in sizes), max(f for _, f in sizes)


def _finish(study: Study, store: TaskStore, attrs: dict, tasks: list) -> dict:
    from ..analysis.ensemble import ensemble_statistics
    from ..analysis.figures import contact_area_vs_load

    groups = combine(study, {t.index: store.path(t.index) for t in tasks})
    root = groups["/"]
    failed = {t.index: str(root["message"].values[t.position]) for t in tasks
              if int(root["status"].values[t.position]) != 0}
    attrs["tasks_failed"] = len(failed)
    # task files of earlier versions have no warnings variable
    warned = sum(1 for t in tasks if "warnings" in root and str(root["warnings"].values[t.position]))
    # the operator and method the first task resolved (each task file records its own)
    kept = ("fields_note", "operator", "method", "solver", "solver_choice")
    root.attrs = {**attrs, **{k: v for k, v in root.attrs.items() if k.startswith(kept)}}
    paths = {"netcdf": write_combined(groups, store.combined), "failed": failed, "warned": warned}
    if "contact_fraction" in root and root["contact_fraction"].notnull().any():
        curves = [name for name in ("contact_fraction", "normal_load") if name in root.data_vars]
        shown = ensemble_statistics(root[curves], "seed") if root.sizes.get("seed", 1) > 1 else root
        grid = f", {root.sizes['x']} × {root.sizes['y']} nodes" if "x" in root.sizes else ""
        paths["figure"] = contact_area_vs_load(
            shown, store.output / f"{study.name}_area_vs_load.png",
            title=f"{study.name}: {math.prod(study.shape)} task(s){grid}")
    return paths


def _provenance(study: Study, comm, k: int, started: str, petsc_options: str) -> dict:
    import numpy
    from mpi4py import MPI
    from petsc4py import PETSc

    attrs = {
        "roughcontact_version": __version__, "study": study.name, "description": study.description,
        "study_definition": study.text, "study_sha256": study.identity,
        "load_dimension": study.load_dim, "fields": study.fields,
        "operator_requested": study.normal.operator, "method_requested": study.normal.method,
        "mpi_ranks": comm.Get_size(), "ranks_per_task": k, "groups": comm.Get_size() // k,
        "started": started, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "petsc_options": petsc_options, "numpy_version": numpy.__version__,
        "petsc_version": ".".join(map(str, PETSc.Sys.getVersion())),
        "mpi_library": MPI.Get_library_version().splitlines()[0],
        **{f"surface_{key}": value for key, value in study.surface.items()},
    }
    if study.interface is not None:
        attrs.update(study.interface.attrs())
    if study.tangential is not None:
        attrs.update(friction=study.tangential.friction, tangential_steps=study.tangential.steps)
    return attrs


def _petsc_options() -> str:
    from petsc4py import PETSc

    return " ".join(f"-{k}" + (f" {v}" if v else "") for k, v in sorted(PETSc.Options().getAll().items()))


def _closing(summary: RunSummary, written: int) -> str:
    lines = [f"{summary.name}: {summary.tasks} task(s): {summary.solved} solved now, {summary.resumed} "
             f"from earlier runs, {len(summary.failed)} failed, {summary.warned} with warnings"
             + (" (see the variable warnings)" if summary.warned else "") + f"; {summary.elapsed:.1f} s"
             + (f", {written / 1e6:.1f} MB of task files" if written else "")]
    reasons: dict[str, list[int]] = {}
    for index, message in sorted(summary.failed.items()):
        reasons.setdefault(": ".join(message.split(": ")[:2]), []).append(index)
    for reason, indices in reasons.items():
        shown = ", ".join(map(str, indices[:10])) + (" …" if len(indices) > 10 else "")
        lines.append(f"  {len(indices)} failed with {reason} (tasks {shown})")
    lines.append("  wrote " + " and ".join(str(p) for p in summary.paths.values()))
    return "\n".join(lines)
