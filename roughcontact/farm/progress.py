"""The progress line of rank 0: tasks done / total, failures, elapsed time and ETA."""
from __future__ import annotations

import sys
import threading
import time


class Progress:
    """Counts finished tasks (thread-safe) and redraws one terminal line as they finish.

    Silent when ``enabled`` is False (``--quiet``) or the stream is not a
    terminal; the counts are kept either way for the closing summary.
    """

    def __init__(self, name: str, total: int, resumed: int, enabled: bool = True, stream=None):
        self.name = name
        self.total = total
        self.resumed = resumed
        self.stream = stream or sys.stderr
        self.enabled = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.solved = 0
        self.failed = 0
        self.written = 0
        self.start = time.perf_counter()
        self._lock = threading.Lock()

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
        if self.enabled and self.solved:
            self.stream.write("\n")
            self.stream.flush()


def _clock(seconds: float) -> str:
    if seconds != seconds:
        return "--:--"
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
