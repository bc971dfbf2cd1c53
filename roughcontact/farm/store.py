"""Where a study's results live on disk, and how a run resumes from them.

Layout under ``--output``::

    <name>.nc                  the combined dataset (written at the end)
    <name>.failure.json        why the last run was aborted (removed by a run that completes)
    <name>.tasks/
        study.json             what the tasks share, the axes and the surface files (before the first solve)
        task-<key>.nc          one file per finished task, completed or failed
        task-<key>.nc.damaged  a file that failed its check, set aside (its task is solved again)

A task's file is named by its key (:func:`~.definition.task_key`), the
hash of what it computes, not by its place in the study: an axis that grows
(more seeds, one more Δ), shrinks or is reordered keeps every finished task;
files of values no longer in the study stay on disk, unused. A change of
what the tasks share (a surface argument that is not an axis, the
materials, the loads, the solver, the fields stored) is refused, naming the
key (:meth:`TaskStore.check_owner`).

Every file is written to ``<file>.part``, flushed to the disk (fsync) and
renamed when complete, so a file under its final name is whole; a kill at
any moment leaves at most a ``.part`` file, removed by the next run. Task
files are still checked when a run starts (:func:`check_task_file`: HDF5
opens, the variables a task has are there, the key is the file's): a
truncated or foreign file is moved aside with a warning and its task solved
again. Each group leader writes the files of the tasks its group solves;
rank 0 writes the manifest and the combined dataset. Any failure to write
is a :class:`~roughcontact.errors.StorageError`: one line with the path, the
count of task files safely on disk and the resume hint.
"""
from __future__ import annotations

import errno
import json
import os
import socket
import time
import zlib
from pathlib import Path
from typing import NamedTuple

import h5py

from .. import __version__
from ..errors import InputError, StorageError

MANIFEST = "study.json"
#: task files named by key (layout 1 named them by position: task-00017.nc)
LAYOUT = 2
#: the suffix of a task file that failed its check
DAMAGED = ".damaged"
#: this host's name as a writer's ``.part`` files carry it (no dots)
HOST = socket.gethostname().replace(".", "_")


class Written(NamedTuple):
    """What a leader reports of a task file it wrote: no field travels to rank 0, only the
    file's small variables (:func:`~.netcdf.held_groups`: what :func:`~.netcdf.read_groups` would
    read of it without fields), which rank 0 keeps for the combined dataset instead of reading
    every file again at the end."""

    index: int
    failed: bool
    size: int
    crc32: int
    content: dict


class Resume(NamedTuple):
    """What a run finds on disk before its first solve."""

    done: set            # keys of the tasks with a whole file (completed only, with retry_failed)
    damaged: list        # (file, why) of the files set aside
    unused: int          # whole task files of values no longer in the study


class TaskStore:
    """The files of one study under an output directory."""

    def __init__(self, output: str | os.PathLike, name: str):
        self.output = Path(output)
        self.name = name
        self.directory = self.output / f"{name}.tasks"
        self.combined = self.output / f"{name}.nc"
        self.failure = self.output / f"{name}.failure.json"

    def path(self, task) -> Path:
        """The file of ``task`` (named by its key)."""
        return self.directory / f"task-{task.key[:24]}.nc"

    def on_disk(self) -> int:
        """How many task files are under their final name now."""
        try:
            return sum(1 for _ in self.directory.glob("task-*.nc"))
        except OSError:
            return 0

    def check_writable(self) -> None:
        """Create the output directory and prove a file can be written there."""
        try:
            self.output.mkdir(parents=True, exist_ok=True)
            probe = self.output / f".{self.name}.write-test-{os.getpid()}"
            probe.write_bytes(b"ok")
            probe.unlink()
        except OSError as exc:
            raise InputError("--output", f"cannot write results under {self.output}: "
                                         f"{exc.strerror or exc}") from None

    def check_owner(self, study) -> bool:
        """Whether the task directory holds tasks of ``study`` already (a resume; False when new).

        Refused, naming the keys: a manifest whose shared part
        (:attr:`~.definition.Study.shared`) differs from ``study``'s, or whose
        measured surface files have changed since. Axes may differ. A
        directory of the earlier layout (files named by position) is renamed
        to keys when its definition is ``study``'s, else refused.
        """
        owner = self._manifest()
        if owner is None:
            return False
        if owner.get("layout") != LAYOUT:
            if owner.get("identity") != study.identity:
                changed = _changed_tables(owner.get("definition", "{}"), study.definition)
                raise InputError("name", (
                    f"{self.directory} holds the tasks of a different definition of study {study.name!r}, "
                    f"written by an earlier version (changed: {changed}). Give this one another name or "
                    f"--output, or delete {self.directory} to start over"))
            self._migrate(study)
            return True
        changed = changed_keys(owner.get("shared", {}), study.shared)
        edited = sorted(p for p, h in study.file_hashes.items()
                        if owner.get("files", {}).get(p, h) != h)
        if changed or edited:
            what = ", ".join(changed + [f"the contents of {p}" for p in edited])
            raise InputError(changed[0] if changed else "surface.path", (
                f"{self.directory} holds tasks of study {study.name!r} computed with other values of "
                f"{what} (written {owner.get('created', '?')}). Only axes may change on a resume (grow, "
                f"shrink, reorder: finished tasks are kept). Give this one another name or --output, or "
                f"delete {self.directory} to start over"))
        return True

    def claim(self, study) -> None:
        """Record ``study`` in the manifest before its first task is written."""
        owner = self._manifest()
        record = {"layout": LAYOUT, "name": study.name, "identity": study.identity,
                  "tasks": len(study.tasks()), "shared": study.shared,
                  "axes": [a.key for d in study.dimensions for a in d.axes], "files": study.file_hashes,
                  "created": (owner or {}).get("created", time.strftime("%Y-%m-%dT%H:%M:%S%z")),
                  "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "roughcontact_version": __version__,
                  "definition": study.definition}
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise self.error("create the task directory", self.directory, exc) from None
        self.write_bytes(self.directory / MANIFEST, json.dumps(record, indent=1).encode(), "the manifest")

    def resume(self, tasks: list, retry_failed: bool = False) -> Resume:
        """The tasks already done, checking each of their files (:func:`check_task_file`).

        A file that fails its check is moved aside to ``<file>.damaged`` and its
        task counts as not done; leftover ``.part`` files of an interrupted
        write are removed. With ``retry_failed``, tasks recorded as failed are
        not done either.
        """
        if not self.directory.exists():
            return Resume(set(), [], 0)
        for part in self.directory.glob("*.part"):
            if _abandoned(part):
                part.unlink(missing_ok=True)
        by_name = {self.path(t).name: t for t in tasks}
        done, damaged, unused = set(), [], 0
        for path in sorted(self.directory.glob("task-*.nc")):
            task = by_name.get(path.name)
            if task is None:
                unused += 1
                continue
            try:
                status = check_task_file(path, task)
            except DamagedFile as exc:
                damaged.append((self.set_aside(path), str(exc)))
                continue
            if not (retry_failed and status != 0):
                done.add(task.key)
        return Resume(done, damaged, unused)

    def set_aside(self, path: Path) -> Path:
        """Move a damaged task file to ``<file>.damaged`` (``.damaged.1``, … if taken); the new path."""
        target = path.with_name(path.name + DAMAGED)
        n = 0
        while target.exists():
            n += 1
            target = path.with_name(f"{path.name}{DAMAGED}.{n}")
        try:
            os.replace(path, target)
        except OSError as exc:
            raise self.error("move a damaged task file aside", path, exc) from None
        return target

    def write_task(self, task, groups: dict) -> Written:
        """Write the file of ``task`` from its datasets (on the group leader that solved it)."""
        from .netcdf import held_groups
        from .records import encode

        payload = encode(groups)
        self.write_bytes(self.path(task), payload, f"the file of {task.name}")
        return Written(task.index, int(groups["/"]["status"]) != 0, len(payload), zlib.crc32(payload),
                       held_groups(groups))

    def write_bytes(self, path: Path, payload: bytes, what: str) -> None:
        """Write ``payload`` to ``path`` through ``path.part``, fsync and a rename.

        Any OSError is a :class:`StorageError` naming ``what`` and the path,
        the ``.part`` file removed.
        """
        part = path.with_name(f"{path.name}.{HOST}.{os.getpid()}.part")
        try:
            _write_file(part, payload)
            os.replace(part, path)
        except OSError as exc:
            try:
                part.unlink(missing_ok=True)
            except OSError:
                pass
            raise self.error(f"write {what}", path, exc) from None

    def error(self, action: str, path, exc: OSError) -> StorageError:
        """The one-line :class:`StorageError` of a failed ``action`` on ``path``."""
        reason = exc.strerror or str(exc)
        hint = " (free space or raise the quota)" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else ""
        return StorageError(path, f"could not {action} {path}: {reason}{hint}; {self.on_disk()} task file(s) "
                                  f"are safely on disk under {self.directory}; run the same command again "
                                  "to resume")

    def record_failure(self, message: str, code: int, rank: int) -> None:
        """Write why the run is aborted to :attr:`failure`, unless a rank has already (the first
        reason wins: the other ranks' errors are its consequences). Best effort: the disk may be full."""
        record = {"time": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "rank": rank, "exit_status": code,
                  "message": message, "task_files_on_disk": self.on_disk()}
        part = self.failure.with_name(f"{self.failure.name}.{os.getpid()}.part")
        try:
            _write_file(part, json.dumps(record, indent=1).encode())
            os.link(part, self.failure)          # atomic, and fails if a record exists
        except OSError:
            pass
        finally:
            try:
                part.unlink(missing_ok=True)
            except OSError:
                pass

    def last_failure(self) -> str | None:
        """The first line of the last aborted run's record, if any."""
        try:
            record = json.loads(self.failure.read_text())
        except (OSError, ValueError):
            return None
        lines = str(record.get("message", "")).strip().splitlines()
        return f"{record.get('time', '?')}, rank {record.get('rank', '?')}: {lines[-1] if lines else '?'}"

    def clear_failure(self) -> None:
        """Remove the failure record (rank 0: once read at the start of a run, and when one completes)."""
        self.failure.unlink(missing_ok=True)

    def _manifest(self) -> dict | None:
        manifest = self.directory / MANIFEST
        if not manifest.exists():
            return None
        try:
            return json.loads(manifest.read_text())
        except (OSError, ValueError) as exc:
            raise InputError("name", f"{manifest} is unreadable ({exc}); delete {self.directory} "
                                     "to start over") from None

    def _migrate(self, study) -> None:
        """Rename layout-1 files (``task-00017.nc``) to their keys, recording the key in each."""
        for task in study.tasks():
            old = self.directory / f"task-{task.index:05d}.nc"
            if not old.exists():
                continue
            try:
                with h5py.File(old, "r+") as f:
                    f.attrs["task_key"] = task.key
            except OSError:
                continue                    # damaged: the check of the next run sets it aside
            os.replace(old, self.path(task))


class DamagedFile(ValueError):
    """A task file that cannot be read, or is not the file of the task it is named for."""


def check_task_file(path: Path, task) -> int:
    """The ``status`` of ``task``'s file (0 completed, 1 failed), or :class:`DamagedFile` saying why.

    HDF5 opens it (a truncated file does not), it has the variables every task
    file has (status, message, the load coordinate) and its ``task_key`` is
    ``task.key``: a file copied in by hand from another study is caught.
    """
    try:
        with h5py.File(path, "r") as f:
            key = f.attrs.get("task_key")
            key = key.decode() if isinstance(key, bytes) else key
            if key != task.key:
                raise DamagedFile(f"it is the file of another task (key {str(key)[:12]}…, not {task.key[:12]}…)")
            missing = [name for name in ("status", "message", task.load_dim) if name not in f]
            if missing:
                raise DamagedFile(f"it lacks {', '.join(missing)}")
            return int(f["status"][()])
    except DamagedFile:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise DamagedFile(f"HDF5 cannot read it: {exc}") from None


def changed_keys(before: dict, after: dict, prefix: str = "") -> list[str]:
    """The dotted keys whose values differ between two nested tables (``normal.loads``)."""
    out = []
    for key in sorted(set(before) | set(after)):
        old, new = before.get(key), after.get(key)
        if isinstance(old, dict) and isinstance(new, dict):
            out += changed_keys(old, new, f"{prefix}{key}.")
        elif old != new:
            out.append(f"{prefix}{key}")
    return out


def _abandoned(part: Path) -> bool:
    """Whether a ``.part`` file is left by a writer that is gone: ``<file>.<host>.<pid>.part`` of a
    dead process of this host, or of another host and older than a stale lease; any other name."""
    from .leases import STALE_SECONDS, _alive

    pieces = part.name.rsplit(".", 3)
    if len(pieces) != 4 or not pieces[2].isdigit():
        return True
    if pieces[1] == HOST:
        return not _alive(int(pieces[2]))
    try:
        return time.time() - part.stat().st_mtime > STALE_SECONDS
    except OSError:
        return False


def _write_file(path: Path, payload: bytes) -> None:
    """Write ``payload`` to ``path`` and flush it to the disk."""
    with open(path, "wb") as stream:
        stream.write(payload)
        stream.flush()
        os.fsync(stream.fileno())


def _changed_tables(before: str, after: str) -> str:
    """The top-level tables that differ between two canonical definitions."""
    try:
        old, new = json.loads(before), json.loads(after)
    except ValueError:
        return "unknown"
    old_study, new_study = old.get("study", {}), new.get("study", {})
    keys = sorted(k for k in set(old_study) | set(new_study) if old_study.get(k) != new_study.get(k))
    if old.get("files") != new.get("files"):
        keys.append("the surface files' contents")
    return ", ".join(keys) or "unknown"
