"""Task claims between jobs that share one ``--output``: exclusive lease files, and shards.

Two jobs on one study (a resubmission while the first still runs, the jobs of
a Slurm array) must neither solve a task twice nor disturb each other. Before
rank 0 hands a task to a group it creates ``<name>.tasks/task-<key>.lease``
with ``O_CREAT | O_EXCL`` (atomic on a local file system and on NFSv3+ and
Lustre): one job gets it; the other leaves the task, and comes back to it
after its other tasks, when the task's file has appeared (solved there) or
the lease has gone stale (its job died). A lease names its job (host, pid and
start time of rank 0); it is stale when that process is gone (same host: no
process with that pid, one that has exited and waits to be reaped (a zombie:
its pid and start time stay in /proc until its parent reaps it, for ever
where an orphan's reaper does not), or one started at another time — pids are reused,
32768 of them on many systems, and a dead job's pid taken by a live process
once kept its leases alive for ever), it is empty and older than
:data:`EMPTY_SECONDS` (its job died between creating and writing it), or it
has not been refreshed for
:data:`STALE_SECONDS` (any host: rank 0 touches its leases every
:data:`HEARTBEAT_SECONDS`). It is removed once its task file is written.

``--shard i/n`` splits a study into n parts by task key, so a part keeps its
tasks when the study grows; a job takes only its part
(:func:`shard_of`), and the last part to finish writes the combined dataset.
"""
from __future__ import annotations

import os
import socket
import threading
import time
from pathlib import Path

from ..errors import InputError

#: a lease not refreshed for this long (s) belongs to a job that is gone
STALE_SECONDS = 120.0
#: how often (s) rank 0 refreshes the leases it holds
HEARTBEAT_SECONDS = 30.0
#: an empty lease older than this (s) is stale: a live job writes its owner into the lease within
#: microseconds of creating it, but a job aborted in between (a full disk on rank 0 while its feeding
#: thread claimed the next task) left it empty, and a resumed run waited STALE_SECONDS on it
EMPTY_SECONDS = 5.0


class Leases:
    """The leases one job holds in a task directory (rank 0 only), refreshed by a daemon thread."""

    def __init__(self, path_of, retrying=(), stale: float = STALE_SECONDS, heartbeat: float = HEARTBEAT_SECONDS):
        self.path_of = path_of                   # task -> its task file
        self.retrying = set(retrying)            # keys whose (failed) file is to be replaced
        self.stale = stale
        self.owner = " ".join(map(str, (socket.gethostname(), os.getpid(), start_time(os.getpid()))))
        self.held: dict[str, Path] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._refresh, args=(heartbeat,), daemon=True)
        self._thread.start()

    def lease_path(self, task) -> Path:
        return self.path_of(task).with_suffix(".lease")

    def claim(self, task) -> bool | None:
        """True: this job now holds the task; False: its file exists (solved elsewhere); None:
        another live job holds it (ask again later)."""
        if self._solved(task):
            return False
        lease = self.lease_path(task)
        for _ in range(2):
            try:
                fd = os.open(lease, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                if not self._is_stale(lease):
                    return None
                taken = lease.with_name(f"{lease.name}.stale.{os.getpid()}")
                try:                             # take a dead job's lease over: one job wins the rename
                    os.replace(lease, taken)
                    taken.unlink(missing_ok=True)
                except FileNotFoundError:
                    pass
                continue
            with os.fdopen(fd, "w") as stream:
                stream.write(self.owner)
            if self._solved(task):               # finished elsewhere between the check and the lease
                lease.unlink(missing_ok=True)
                return False
            with self._lock:
                self.held[task.key] = lease
            return True
        return None

    def _solved(self, task) -> bool:
        return task.key not in self.retrying and self.path_of(task).exists()

    def release(self, task) -> None:
        with self._lock:
            lease = self.held.pop(task.key, None)
        if lease is not None:
            lease.unlink(missing_ok=True)

    def close(self) -> None:
        """Stop refreshing and remove the leases still held (tasks not finished: free for others)."""
        self._stop.set()
        self._thread.join()
        with self._lock:
            for lease in self.held.values():
                try:
                    lease.unlink(missing_ok=True)
                except OSError:
                    pass
            self.held.clear()

    def _refresh(self, heartbeat: float) -> None:
        while not self._stop.wait(heartbeat):
            with self._lock:
                leases = list(self.held.values())
            for lease in leases:
                try:
                    os.utime(lease)
                except OSError:
                    pass

    def _is_stale(self, lease: Path) -> bool:
        try:
            owner = lease.read_text().split()
            age = time.time() - lease.stat().st_mtime
        except (OSError, ValueError):
            return False                          # being written or just removed: ask again
        if len(owner) in (2, 3) and owner[0] == socket.gethostname():
            return not _alive(int(owner[1]), owner[2] if len(owner) == 3 else None)
        if not owner:                             # never written: its job died between open and write
            return age > min(EMPTY_SECONDS, self.stale)
        return age > self.stale


def _stat(pid: int) -> list[str] | None:
    """The fields of /proc/<pid>/stat after the command name (the first: the state), or None where
    /proc does not say."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None


def start_time(pid: int) -> str:
    """When process ``pid`` started (clock ticks since boot, /proc/<pid>/stat field 22), or "-"
    where /proc does not say (then only the pid identifies the process)."""
    return _started(_stat(pid))


def _started(fields: list[str] | None) -> str:
    """The start time among the fields of :func:`_stat`, or "-"."""
    return fields[19] if fields is not None and len(fields) > 19 else "-"


def _alive(pid: int, started: str | None = None) -> bool:
    """Whether process ``pid`` exists, has not exited (a zombie, not yet reaped by its parent, has)
    and, when ``started`` is known, is the one started then."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    fields = _stat(pid)                        # one read of /proc for the state and the start
    if fields and fields[0] in ("Z", "X"):      # exited, not yet reaped
        return False
    if started is None or started == "-":
        return True
    now = _started(fields)
    return now == "-" or now == started


def parse_shard(text: str | None) -> tuple[int, int] | None:
    """``"i/n"`` (0 ≤ i < n) as (i, n); None: no shard, unless Slurm's array variables give one.

    The default is ``SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN`` of
    ``SLURM_ARRAY_TASK_COUNT`` when a job array sets them.
    """
    if text is None:
        env = os.environ
        if "SLURM_ARRAY_TASK_ID" in env and "SLURM_ARRAY_TASK_COUNT" in env:
            text = f"{int(env['SLURM_ARRAY_TASK_ID']) - int(env.get('SLURM_ARRAY_TASK_MIN', 0))}/" \
                   f"{env['SLURM_ARRAY_TASK_COUNT']}"
        else:
            return None
    try:
        i, n = (int(part) for part in text.split("/"))
    except ValueError:
        raise InputError("--shard", f"must be i/n with 0 <= i < n, got {text!r}") from None
    if not 0 <= i < n:
        raise InputError("--shard", f"must be i/n with 0 <= i < n, got {text!r}")
    return i, n


def shard_of(key: str, count: int) -> int:
    """The shard (0 … count − 1) of a task key: stable when the study grows or is reordered."""
    return int(key[:12], 16) % count
