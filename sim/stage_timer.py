"""Wall-clock time per named stage of the frame loop, summed over threads (``bench generate``).

A :class:`StageTimer` is handed to the parts of the loop (renderer, noise step, writers); each wraps a
stage in ``with timer.stage("encode"):``. Stages run concurrently in the pipeline's worker threads, so
the sums are thread-seconds, not elapsed time. :data:`NO_TIMER` measures nothing (the default).
"""
from __future__ import annotations

import threading
import time
from contextlib import contextmanager, nullcontext


class StageTimer:
    """Thread-safe sums of seconds and counts per stage name."""

    def __init__(self):
        self._lock = threading.Lock()
        self._seconds: dict = {}
        self._counts: dict = {}

    @contextmanager
    def stage(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0)

    def add(self, name: str, seconds: float) -> None:
        with self._lock:
            self._seconds[name] = self._seconds.get(name, 0.0) + float(seconds)
            self._counts[name] = self._counts.get(name, 0) + 1

    def add_max(self, name: str, value: float) -> None:
        """Keep the largest ``value`` under ``name`` (a peak, e.g. a worker process's memory), not a sum."""
        with self._lock:
            self._seconds[name] = max(self._seconds.get(name, float(value)), float(value))
            self._counts[name] = self._counts.get(name, 0) + 1

    def seconds(self, name: str) -> float:
        with self._lock:
            return self._seconds.get(name, 0.0)

    def totals(self) -> dict:
        """``{stage: seconds}`` summed so far."""
        with self._lock:
            return dict(self._seconds)


class _NoTimer:
    def stage(self, name: str):
        return nullcontext()

    def add(self, name: str, seconds: float) -> None:
        pass

    def add_max(self, name: str, value: float) -> None:
        pass


NO_TIMER = _NoTimer()
