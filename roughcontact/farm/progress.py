"""The progress of rank 0: tasks done / total, failures, elapsed time and ETA.

On a terminal one line is redrawn as tasks finish; otherwise (a batch log)
a full line is written every ``interval`` seconds (``ROUGHCONTACT_PROGRESS_SECONDS``,
default 60) while tasks remain, by a daemon thread, so a log shows a run
alive even while no task finishes.
"""
from __future__ import annotations

import os
import sys
import threading
import time

#: seconds between progress lines in a batch log (the environment variable overrides it)
INTERVAL = 60.0


class Progress:
    """Counts finished tasks (thread-safe) and shows them: a redrawn terminal line, or a line
    every ``interval`` seconds when the stream is not a terminal.

    Silent when ``enabled`` is False (``--quiet``); the counts are kept either
    way for the closing summary.
    """

    def __init__(self, name: str, total: int, resumed: int, enabled: bool = True, stream=None,
                 interval: float | None = None):
        self.name = name
        self.total = total
        self.resumed = resumed
        self.stream = stream or sys.stderr
        terminal = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.enabled = enabled and terminal
        self.solved = 0
        self.failed = 0
        self.written = 0
        self.start = time.perf_counter()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ticker = None
        if enabled and not terminal and resumed < total:
            seconds = interval if interval is not None else float(os.environ.get("ROUGHCONTACT_PROGRESS_SECONDS",
                                                                                 INTERVAL))
            self._ticker = threading.Thread(target=self._tick, args=(seconds,), daemon=True)
            self._ticker.start()

    def _tick(self, seconds: float) -> None:
        while not self._stop.wait(seconds):
            with self._lock:
                self.stream.write(self.line().rstrip() + "\n")
                self.stream.flush()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def task_done(self, failed: bool, nbytes: int) -> None:
        with self._lock:
            self.solved += 1
            self.written += nbytes
            self.failed += bool(failed)
            if self.enabled:
                self.stream.write("\r" + self.line())
                self.stream.flush()

    def line(self) -> str:
        done = self.resumed + self.solved
        remaining = self.total - done
        eta = self.elapsed / self.solved * remaining if self.solved else float("nan")
        return (f"{self.name}: {done}/{self.total} tasks, {self.failed} failed, "
                f"{_clock(self.elapsed)} elapsed, ETA {_clock(eta)}  ")

    def close(self) -> None:
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
        if self.enabled and self.solved:
            self.stream.write("\n")
            self.stream.flush()


def _clock(seconds: float) -> str:
    if seconds != seconds:
        return "--:--"
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
