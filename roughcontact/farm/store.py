"""Where a study's results live on disk, and how a run resumes from them.

Layout under ``--output``::

    <name>.nc              the combined dataset (written at the end)
    <name>.tasks/
        study.json         the study's identity and definition (written before the first solve)
        task-00017.nc      one file per finished task, completed or failed

Every file is written to ``<file>.part`` and renamed when complete, so a
file under its final name is whole: a kill at any moment (during a write
included) leaves at most a ``.part`` file, removed by the next run, and
the next run recomputes exactly the tasks without a file. Only rank 0 of
the farm touches these files.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import h5py

from .. import __version__
from ..errors import InputError

MANIFEST = "study.json"


class TaskStore:
    """The files of one study under an output directory."""

    def __init__(self, output: str | os.PathLike, name: str):
        self.output = Path(output)
        self.name = name
        self.directory = self.output / f"{name}.tasks"
        self.combined = self.output / f"{name}.nc"

    def path(self, index: int) -> Path:
        """The file of task ``index``."""
        return self.directory / f"task-{index:05d}.nc"

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
        """Whether the task directory holds ``study`` already (a resume; False when it is new).

        A different definition under the same name is refused: its tasks
        would not be comparable with this one's.
        """
        manifest = self.directory / MANIFEST
        if not manifest.exists():
            return False
        try:
            owner = json.loads(manifest.read_text())
        except (OSError, ValueError) as exc:
            raise InputError("name", f"{manifest} is unreadable ({exc}); delete {self.directory} "
                                     "to start over") from None
        if owner.get("identity") != study.identity:
            changed = _changed_tables(owner.get("definition", "{}"), study.definition)
            raise InputError("name", (
                f"{self.directory} holds the tasks of a different definition of study {study.name!r} "
                f"(written {owner.get('created', '?')}; changed: {changed}). Give this one another "
                f"name or --output, or delete {self.directory} to start over"))
        return True

    def claim(self, study) -> None:
        """Record ``study`` as the owner of the task directory (before its first task is written)."""
        if self.check_owner(study):
            return
        self.directory.mkdir(parents=True, exist_ok=True)
        record = {"identity": study.identity, "name": study.name, "tasks": len(study.tasks()),
                  "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "roughcontact_version": __version__,
                  "definition": study.definition}
        self.write_bytes(self.directory / MANIFEST, json.dumps(record, indent=1).encode())

    def finished(self, retry_failed: bool = False) -> set[int]:
        """Indices of the tasks with a file; with ``retry_failed``, only the completed ones.

        Leftover ``.part`` files of an interrupted write are removed.
        """
        if not self.directory.exists():
            return set()
        for stale in self.directory.glob("*.part"):
            stale.unlink(missing_ok=True)
        done = set()
        for path in self.directory.glob("task-*.nc"):
            index = int(path.stem.split("-")[1])
            if retry_failed and task_status(path) != 0:
                continue
            done.add(index)
        return done

    def write(self, index: int, payload: bytes) -> int:
        """Store the file of task ``index`` atomically; returns its size in bytes."""
        self.write_bytes(self.path(index), payload)
        return len(payload)

    @staticmethod
    def write_bytes(path: Path, payload: bytes) -> None:
        """Write ``payload`` to ``path`` through ``path.part`` and a rename."""
        part = path.with_name(path.name + ".part")
        with open(part, "wb") as stream:
            stream.write(payload)
        os.replace(part, path)


def task_status(path: Path) -> int:
    """The ``status`` of a task file (0 completed, 1 failed)."""
    with h5py.File(path, "r") as f:
        return int(f["status"][()])


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
