"""The task farm: groups of ranks solve tasks; rank 0 receives each result as it finishes.

The communicator is split into groups of k consecutive ranks (as
Firedrake's ``Ensemble`` does): each group solves one task at a time with
its operator distributed over the group, and the groups' rank 0s (the
leaders) form the communicator of an ``mpi4py.futures.MPICommExecutor``.
Rank 0 submits tasks to the other leaders, at most one in flight each, from
the executor's manager thread (a finished task's callback delivers the
result and submits the next), while its main thread solves tasks itself, so
no rank only waits. Leaders broadcast each task to their group; the other
ranks of a group loop on that broadcast until told to stop.

Any exception that escapes a task on any rank (a defect, not bad input nor a
non-converging solve, which tasks record as failures) prints its message
with the rank and aborts the whole job: the other ranks never wait forever
in a collective. A task file that cannot be written (a
:class:`~roughcontact.errors.StorageError`) aborts it the same way with one
line and :data:`STORAGE_CODE`. Before aborting, the message is written to the
failure record (:func:`record_failures_with`) and the rank waits until the
launcher has read it from the stderr pipe: MPI_Abort kills the launcher's
forwarding too, and lost the message in 7 of 150 trials without the wait (0 of
150 with it). Finished tasks are on disk already, so the next run resumes.
"""
from __future__ import annotations

import os
import stat
import sys
import threading
import time
import traceback
from collections import deque
from typing import Callable

from ..errors import InputError, RoughContactError, StorageError

#: exit status of a job aborted by an unexpected error on some rank (sysexits' EX_SOFTWARE)
ABORT_CODE = 70
#: exit status of a run that could not write or read its files (sysexits' EX_IOERR)
STORAGE_CODE = 74
#: exit status of a run drained by SIGTERM or SIGUSR1 before its tasks were done (sysexits' EX_TEMPFAIL)
DRAIN_CODE = 75
#: the longest wait (s) for the launcher to read an abort's message from the stderr pipe
DRAIN_LIMIT = 5.0

#: the interpreter's switch interval (s) on rank 0 while it solves and feeds the other leaders
SWITCH_INTERVAL = 2e-4

_STATE: dict = {}      # the work function and groups of this process, for tasks sent to it
_RECORD: list = []     # where an abort writes its failure record: record(message, code, rank)


class Groups:
    """``comm`` split into groups of ``size`` consecutive ranks, and the communicator of their leaders."""

    def __init__(self, comm, size: int):
        from mpi4py import MPI

        group_count(comm.Get_size(), size)
        rank = comm.Get_rank()
        self.comm = comm
        self.group = comm.Split(rank // size, rank)
        self.is_leader = self.group.Get_rank() == 0
        self.leaders = comm.Split(0 if self.is_leader else MPI.UNDEFINED, rank)

    def free(self) -> None:
        from mpi4py import MPI

        if self.leaders != MPI.COMM_NULL:
            self.leaders.Free()
        self.group.Free()


def group_count(ranks: int, size) -> int:
    """How many groups of ``size`` ranks ``ranks`` make, or :class:`InputError` unless ``size`` divides it."""
    if isinstance(size, bool) or not isinstance(size, int) or size < 1 or ranks % size:
        raise InputError("farm.ranks_per_task", f"{size!r} does not divide the {ranks} rank(s) of the run; "
                                                f"use a divisor of {ranks} (or run on a multiple of {size})")
    return ranks // size


class TaskQueue:
    """Rank 0's queue of tasks: each taken once, if ``claim(task)`` allows (thread-safe).

    ``claim`` returns True (take it), False (drop it: done elsewhere) or None
    (another job holds it: ask again once the others are handed out, every
    ``poll`` seconds). After :meth:`drain` nothing more is handed out.
    """

    def __init__(self, tasks, claim: Callable | None = None, poll: float = 1.0):
        self.queue = deque(tasks)
        self.claim = claim
        self.poll = poll
        self.draining = threading.Event()
        self.lock = threading.Lock()
        self.dropped = 0

    def drain(self) -> None:
        self.draining.set()

    @property
    def left(self) -> int:
        """Tasks not handed out (with those another job holds)."""
        return len(self.queue)

    def take(self):
        with self.lock:
            deferred = 0
            while self.queue and not self.draining.is_set():
                task = self.queue.popleft()
                verdict = True if self.claim is None else self.claim(task)
                if verdict:
                    return task
                if verdict is False:
                    self.dropped += 1
                    deferred = 0
                    continue
                self.queue.append(task)                    # held by another job: after the others
                deferred += 1
                if deferred >= len(self.queue):            # only such tasks are left: wait for them
                    self.draining.wait(self.poll)
                    deferred = 0
            return None


def run_farm(tasks, comm, ranks_per_task: int, work: Callable, deliver: Callable,
             backoff: float = 0.002, root_works: bool = True) -> None:
    """Solve ``tasks`` (a list, or a :class:`TaskQueue` on rank 0) on groups of ``ranks_per_task``
    ranks of ``comm`` (collective).

    ``work(task, group_comm)`` runs on every rank of the group that takes the
    task; its value on the group's leader reaches ``deliver(task, value)`` on
    rank 0 of ``comm``, called from the main thread or from the executor's
    manager thread (so it must be thread-safe), as soon as the task finishes.
    ``backoff`` is the longest sleep (s) of the executor's polling loops.
    ``root_works`` lets rank 0's group solve tasks while rank 0 hands them
    out (when MPI gives threads; with one group it always solves).
    """
    from mpi4py import MPI
    from mpi4py.futures import MPICommExecutor

    groups = Groups(comm, ranks_per_task)
    _STATE.update(work=work, groups=groups)
    try:
        if not groups.is_leader:
            while (task := groups.group.bcast(None, root=0)) is not None:
                _guarded(work, task, groups.group, comm)
            return
        queue = tasks if isinstance(tasks, TaskQueue) else TaskQueue(tasks)
        if groups.leaders.Get_size() == 1:
            while (task := queue.take()) is not None:
                deliver(task, _lead(task))
        else:
            with MPICommExecutor(groups.leaders, root=0, backoff=backoff) as executor:
                if executor is not None:
                    root_works = root_works and MPI.Query_thread() >= MPI.THREAD_MULTIPLE
                    try:
                        _feed(executor, queue, deliver, groups.leaders.Get_size() - 1, root_works, comm)
                    except BaseException:   # abort now: leaving the block would wait for the workers
                        abort(comm, f"roughcontact: rank 0: {traceback.format_exc()}")
        if groups.group.Get_size() > 1:
            groups.group.bcast(None, root=0)
    except BaseException:
        if comm.Get_size() == 1:
            raise
        abort(comm, f"roughcontact: rank {comm.Get_rank()} of {comm.Get_size()}: {traceback.format_exc()}")
    finally:
        _STATE.clear()
        groups.free()


def _feed(executor, queue: TaskQueue, deliver, remote_workers: int, root_works: bool, comm) -> None:
    """Rank 0: keep one task in flight per remote leader, solve the rest here."""
    # the manager thread creates its intercommunicator first: MPICH may deadlock when it does so
    # while this thread creates the communicators of a solve (PETSc duplicates them)
    executor.bootup(wait=True)
    outstanding: set = set()
    settled = threading.Condition()
    take = queue.take

    def submit():
        task = take()
        if task is None:
            return
        future = executor.submit(_lead, task)
        with settled:
            outstanding.add(future)
        future.add_done_callback(lambda f: finished(f, task))

    def finished(future, task):      # the manager thread, as soon as the leader answers
        try:
            result = future.result()
            submit()                     # the leader's next task leaves when this returns
            deliver(task, result)
        except BaseException:
            abort(comm, f"roughcontact: rank 0: could not take the result of task {task.index}: "
                        f"{traceback.format_exc()}")
        with settled:
            outstanding.discard(future)
            settled.notify_all()

    for _ in range(remote_workers):
        submit()
    # the manager thread needs the interpreter lock to answer a leader; while this thread
    # solves, it would wait up to the switch interval (5 ms) several times per task
    interval = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL)
    try:
        while root_works and (task := take()) is not None:
            deliver(task, _lead(task))
    finally:
        sys.setswitchinterval(interval)
    with settled:
        settled.wait_for(lambda: not outstanding)


def _lead(task):
    """A task on a leader: on rank 0, or on another leader (called by the executor's worker loop)."""
    groups = _STATE["groups"]
    if groups.group.Get_size() > 1:
        groups.group.bcast(task, root=0)
    return _guarded(_STATE["work"], task, groups.group, groups.comm)


def _guarded(work, task, group, comm):
    try:
        return work(task, group)
    except StorageError as exc:
        if comm.Get_size() == 1:
            raise
        abort(comm, f"roughcontact: error: {exc}", STORAGE_CODE)
    except BaseException:
        if comm.Get_size() == 1:
            raise
        abort(comm, f"roughcontact: rank {comm.Get_rank()} of {comm.Get_size()}: unexpected error in "
                    f"{getattr(task, 'name', task)}:\n{traceback.format_exc()}")


class record_failures_with:
    """Within this block, :func:`abort` first calls ``record(message, code, rank)`` (the run's
    failure record on disk)."""

    def __init__(self, record: Callable):
        self.record = record

    def __enter__(self):
        _RECORD.append(self.record)
        return self

    def __exit__(self, *exc):
        _RECORD.remove(self.record)


def abort(comm, message: str, code: int = ABORT_CODE) -> None:
    """Record and print ``message`` and abort every rank of ``comm`` with ``code`` (never returns)."""
    message = message.rstrip()
    for record in _RECORD[-1:]:
        try:
            record(message, code, comm.Get_rank())
        except BaseException:          # a failure record is best effort: the disk may be the fault
            pass
    sys.stderr.write(message + "\n")
    sys.stderr.flush()
    _wait_for_reader(sys.stderr.fileno())
    comm.Abort(code)
    # MPICH's MPI_Abort returned here 3 times in 40 runs of a full disk on rank 0 while its manager
    # thread served the other leader: the caller then went on with a result it never got and
    # printed a second, misleading error; this process ends now, with the code
    os._exit(code)


def _wait_for_reader(fd: int, limit: float = DRAIN_LIMIT) -> None:
    """Until a pipe's reader (the MPI launcher) has taken every byte written to it, at most ``limit`` s.

    Only for a pipe (FIONREAD is the unread byte count of the pipe); a file or a
    terminal holds what was written already.
    """
    import fcntl
    import struct
    import termios

    try:
        if not stat.S_ISFIFO(os.fstat(fd).st_mode):
            return
        deadline = time.monotonic() + limit
        while time.monotonic() < deadline:
            if struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0] == 0:
                return
            time.sleep(0.001)
    except OSError:
        return


def on_root(comm, function: Callable, *args):
    """``function(*args)`` on rank 0, its value on every rank.

    A :class:`~roughcontact.errors.RoughContactError` it raises is raised on
    every rank; anything else aborts the job (another rank would wait for
    rank 0 forever otherwise).
    """
    value = error = None
    if comm.Get_rank() == 0:
        try:
            value = function(*args)
        except RoughContactError as exc:
            error = (type(exc), str(exc), dict(exc.__dict__))
        except BaseException:
            if comm.Get_size() == 1:
                raise
            abort(comm, f"roughcontact: rank 0: {traceback.format_exc()}")
    value, error = comm.bcast((value, error), root=0)
    if error is not None:
        cls, text, attrs = error
        exc = cls.__new__(cls)
        Exception.__init__(exc, text)
        exc.__dict__.update(attrs)
        raise exc
    return value
