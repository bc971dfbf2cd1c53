"""Run a study on a communicator: checks, the farm, the combined dataset, statistics and the figure.

:func:`run_study` is what ``roughcontact run`` does. Order matters: the
output directory is checked writable and claimed, finished tasks are found
(resume), the memory of the largest operator is checked and the size of the
results printed, all before the first solve; each task is on disk as soon as
it finishes; the combined dataset is written last.
"""
from __future__ import annotations

import math
import signal
import sys
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .. import __version__
from ..errors import InputError, StorageError
from .combine import Combiner, combine, read_shared
from .definition import Study
from .executor import DRAIN_CODE, STORAGE_CODE, TaskQueue, group_count, on_root, record_failures_with, run_farm
from .guards import (
    check_combine_memory,
    check_operator_memory,
    oversubscription,
    storage_estimate,
    straddling,
    task_size,
)
from .leases import Leases, shard_of
from .progress import Progress
from .records import FAILED, task_groups
from .store import DAMAGED, TaskStore
from .task import solve_task


@dataclass
class RunSummary:
    """What a run did, on every rank."""

    name: str
    tasks: int
    resumed: int
    solved: int
    failed: dict[int, str] = field(default_factory=dict)
    missing: dict[int, str] = field(default_factory=dict)
    warned: int = 0
    waiting: int = 0             # tasks not on disk at the end (other shards or jobs, or drained)
    drained: bool = False
    paths: dict[str, Path] = field(default_factory=dict)
    elapsed: float = 0.0
    solved_here: int = 0

    @property
    def exit_code(self) -> int:
        """0 when every task completed (or, for a shard, its part); 1 when some failed (their
        results are recorded) or have no result (a file damaged after it was written: the next
        run solves it again); :data:`~.executor.DRAIN_CODE` when drained by a signal."""
        if self.drained:
            return DRAIN_CODE
        return 1 if self.failed or self.missing else 0


def run_study(study: Study, comm, output: str | Path, log: Callable = print, quiet: bool = False,
              retry_failed: bool = False, ranks_per_task: int | None = None,
              shard: tuple[int, int] | None = None) -> RunSummary:
    """Solve every task of ``study`` not already on disk under ``output``, then combine them.

    Collective over ``comm``. Writes ``<output>/<name>.tasks/task-*.nc`` as
    tasks finish, then ``<output>/<name>.nc`` and, when a load sweep has
    completed, ``<output>/<name>_area_vs_load.png`` (Fig. 5a, with
    confidence bands over seeds). ``ranks_per_task`` overrides the study's.
    ``retry_failed`` solves again the tasks recorded as failed. ``shard``
    (i, n) solves only part i of n (:func:`~.leases.shard_of`). Tasks are
    claimed by lease files (:mod:`.leases`), so jobs sharing ``output`` split
    the work; the combined dataset is written by the run that finds every
    task on disk at its end. SIGTERM or SIGUSR1 drains the run: no new task
    starts, those in flight finish, and it ends with :data:`DRAIN_CODE`.
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
    found = on_root(comm, _resume, store, study, tasks, retry_failed)
    if rank == 0:
        _warn_found(store, found)
    pending = [t for t in tasks if t.key not in found.done]
    if shard is not None:
        pending = [t for t in pending if shard_of(t.key, shard[1]) == shard[0]]
    count = group_count(comm.Get_size(), k)      # refuses a k that does not divide the ranks
    grid, footprint = on_root(comm, _sizes, pending)
    on_root(comm, check_combine_memory, study, grid)
    if pending:
        check_operator_memory(study, footprint, comm, k)
        if pending[0].surface["generator"] != "file":     # measured surfaces: read whole by task_size
            on_root(comm, _build_surface, pending[0])
    for warning in (oversubscription(comm), straddling(comm, k)):
        if warning and rank == 0:
            print(f"roughcontact: warning: {warning}", file=sys.stderr)
    resumed = len(tasks) - len(pending)
    say(f"{study.name}: {len(tasks)} task(s), {resumed} already done"
        + (f", shard {shard[0]}/{shard[1]}: {len(pending)} to solve" if shard else "")
        + f", {comm.Get_size()} rank(s) in {count} group(s) of {k}, operator {study.normal.operator}, "
          f"method {study.normal.method}")
    if pending:
        say(f"  storage: {storage_estimate(study, grid)}")
    on_root(comm, store.claim, study)
    progress = Progress(study.name, len(tasks), resumed, enabled=not quiet and rank == 0)
    solved_here = [0]

    def work(task, group):
        outcome = solve_task(task, group, timeout=study.task_timeout)
        solved_here[0] += 1
        if group.Get_rank() != 0:
            return None
        groups = task_groups(outcome)       # the file names the study that wrote it, beside its own key
        groups["/"].attrs.update(study=study.name, study_sha256=study.identity)
        # the leader writes the file itself: no result travels through rank 0
        return store.write_task(task, groups)

    retrying = {t.key for t in pending if store.path(t).exists()} if rank == 0 and retry_failed else ()
    leases = Leases(store.path, retrying) if rank == 0 else None
    queue = TaskQueue(pending, leases.claim) if leases is not None else pending

    # rank 0 places each task's small variables as it finishes: no task file is read again at the end
    combiner = Combiner(study) if rank == 0 else None

    def deliver(task, written):
        combiner.add(task, written.content, store.path(task))
        leases.release(task)
        progress.task_done(written.failed, written.size)

    try:
        with record_failures_with(store.record_failure), _draining(queue if rank == 0 else None):
            try:
                run_farm(queue, comm, k, work, deliver, root_works=study.root_works)
            finally:
                if leases is not None:
                    leases.close()
            progress.close()
            drained = comm.bcast(rank == 0 and queue.draining.is_set() and queue.left > 0, root=0)
            waiting = on_root(comm, lambda: sum(not store.path(t).exists() for t in tasks))
            paths = {"failed": {}, "missing": {}, "warned": 0}
            if not waiting:
                # the tasks of earlier runs: their files read by every rank, not by rank 0 alone
                read_shared(combiner, tasks, store.path, comm)
                attrs = _provenance(study, comm, k, started, _petsc_options())
                paths = on_root(comm, _finish, study, store, attrs, tasks, combiner)
    except StorageError as exc:           # raised here on one rank, or by rank 0 on every rank
        if rank == 0:
            store.record_failure(f"roughcontact: error: {exc}", STORAGE_CODE, rank)
        raise
    solved = comm.bcast(progress.solved, root=0)
    summary = RunSummary(name=study.name, tasks=len(tasks), resumed=resumed, solved=solved,
                         failed=paths.pop("failed"), missing=paths.pop("missing"), warned=paths.pop("warned"),
                         paths=paths, elapsed=time.perf_counter() - t0, solved_here=solved_here[0],
                         waiting=waiting, drained=drained)
    say(_closing(summary, progress.written))
    return summary


@contextmanager
def _draining(queue):
    """SIGTERM and SIGUSR1 (a wall-time limit coming) drain ``queue`` (rank 0) instead of killing
    the rank; on the other ranks they are noted and ignored, so tasks in flight finish."""
    def handler(signum, frame):
        if queue is not None:
            if not queue.draining.is_set():
                print(f"roughcontact: {signal.Signals(signum).name}: draining: no new task starts, those "
                      "in flight finish; the same command resumes", file=sys.stderr, flush=True)
            queue.drain()

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGUSR1)}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def combine_study(study: Study, output: str | Path, log: Callable = print, comm=None) -> RunSummary:
    """Combine the task files of ``study`` under ``output`` into ``<name>.nc``, solving nothing.

    What ``roughcontact combine`` does: on one process (no MPI launcher
    needed), or collectively on ``comm``, whose ranks share the reading of the
    task files (:func:`~.combine.read_shared`) while rank 0 checks them first
    and writes the dataset. The files are checked as a run checks them
    (damaged ones moved aside); tasks without a file are left without a result
    (status −1) and counted as missing, so the same ``roughcontact run``
    completes them.
    """
    from mpi4py import MPI

    comm = comm or MPI.COMM_SELF
    t0 = time.perf_counter()
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    tasks = study.tasks()
    store = TaskStore(output, study.name)

    def check():
        if not store.check_owner(study):
            raise InputError("--output", f"no task files of study {study.name!r} under {output} (no "
                                         f"{store.directory}); run it first")
        _warn_found(store, store.resume(tasks))
        check_combine_memory(study, _sizes(tasks)[0])

    on_root(comm, check)
    combiner = Combiner(study) if comm.Get_rank() == 0 else None
    read_shared(combiner, tasks, store.path, comm)
    # the provenance of the solves (one rank per task and group as far as the combine knows)
    attrs = _provenance(study, MPI.COMM_SELF, study.ranks_per_task, started, _petsc_options())
    paths = on_root(comm, _finish, study, store, attrs, tasks, combiner)
    missing = paths.pop("missing")
    summary = RunSummary(name=study.name, tasks=len(tasks), resumed=len(tasks) - len(missing), solved=0,
                         failed=paths.pop("failed"), missing=missing, warned=paths.pop("warned"), paths=paths,
                         elapsed=time.perf_counter() - t0)
    if comm.Get_rank() == 0:
        log(_closing(summary, 0))
    return summary


def _warn_found(store: TaskStore, found) -> None:
    """Rank 0: what the check of the task files found, and the last run's abort."""
    last = store.last_failure()
    if last:
        print(f"roughcontact: note: the last run of {store.name} was aborted ({last}); resuming", file=sys.stderr)
        store.clear_failure()
    for path, why in found.damaged:
        print(f"roughcontact: warning: a task file was damaged ({why}): moved aside to {path}; its task is "
              "solved again", file=sys.stderr)
    if found.unused:
        print(f"roughcontact: note: {found.unused} task file(s) under {store.directory} hold values no longer "
              "in the study: kept, not combined", file=sys.stderr)


def _build_surface(task) -> None:
    """Build a task's surface once and drop it: bad generator arguments (a generated surface is
    only sized, not built, before this) are an InputError before any solve."""
    task.topography()


def _resume(store: TaskStore, study: Study, tasks: list, retry_failed: bool):
    """Check the output is writable and holds no other study; the tasks already done (:class:`~.store.Resume`)."""
    store.check_writable()
    store.check_owner(study)
    return store.resume(tasks, retry_failed)


def _sizes(tasks: list) -> tuple[int, int]:
    """The largest grid and footprint (nodes) over ``tasks``."""
    sizes = [task_size(t) for t in tasks] or [(0, 0)]
    return max(g for g, _ in sizes), max(f for _, f in sizes)


def _finish(study: Study, store: TaskStore, attrs: dict, tasks: list, combiner: Combiner | None = None) -> dict:
    from ..analysis.ensemble import ensemble_statistics
    from ..analysis.figures import contact_area_vs_load

    missing = {}

    def damaged(task, path, why):
        if not path.exists():
            missing[task.index] = "no task file"
            return
        missing[task.index] = f"{why}; moved aside to {store.set_aside(path)}"
        print(f"roughcontact: warning: the file of {task.name} was damaged ({why}): moved aside to "
              f"{path.name}{DAMAGED}; the next run solves it again", file=sys.stderr)

    combined = combine(study, {t.index: store.path(t) for t in tasks}, damaged, combiner)
    root = combined.groups["/"]
    failed = {t.index: str(root["message"].values[t.position]) for t in tasks
              if int(root["status"].values[t.position]) == FAILED}
    attrs["tasks_failed"] = len(failed)
    attrs["tasks_missing"] = len(missing)
    # task files of earlier versions have no warnings variable
    warned = sum(1 for t in tasks if "warnings" in root and str(root["warnings"].values[t.position]))
    # the operator and method the first task resolved (each task file records its own)
    kept = ("fields_note", "operator", "method", "solver", "solver_choice")
    root.attrs = {**attrs, **{k: v for k, v in root.attrs.items() if k.startswith(kept)}}
    try:
        written = combined.write(store.combined)
    except OSError as exc:
        raise store.error("write the combined dataset", store.combined, exc) from None
    store.clear_failure()
    paths = {"netcdf": written, "failed": failed, "missing": missing, "warned": warned}
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
    if summary.missing:
        shown = ", ".join(map(str, sorted(summary.missing)[:10])) + (" …" if len(summary.missing) > 10 else "")
        lines.append(f"  {len(summary.missing)} without a result (no task file, or a damaged one moved aside; "
                     f"tasks {shown}): roughcontact run of the same study solves them")
    if summary.drained:
        lines.append(f"  drained by a signal: {summary.waiting} task(s) not solved; run the same command again "
                     "to resume")
    elif summary.waiting:
        lines.append(f"  not combined: {summary.waiting} task(s) of other shards or jobs are not on disk yet; "
                     "the run that finishes last combines (or roughcontact combine)")
    if summary.paths:
        lines.append("  wrote " + " and ".join(str(p) for p in summary.paths.values()))
    return "\n".join(lines)
