"""An ordered, bounded pipeline for the per-frame CPU work of dataset generation.

The caller's thread (the one that owns the GL context) renders frame after frame and hands each frame's
remaining work (noise and effects, PNG encoding, writing its files) to :meth:`FramePipeline.submit`; a
pool of worker threads does that work (OpenCV's encoders and numpy's bulk operations release the GIL),
and each frame's ``commit`` (its CSV rows and the progress marker) runs back on the caller's thread in
submission order, once its work is done. At most ``depth`` frames are in flight: a :meth:`submit`
beyond that first commits the oldest, so memory stays bounded whatever the route length.

``threads = 0`` runs every job inline at :meth:`submit` (the serial loop). On an exception (also
``KeyboardInterrupt``) inside the ``with`` block, frames not yet started are dropped and running ones
finish; their files (written atomically) carry no row, so a resumed run rewrites them.
"""
from __future__ import annotations

import os
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from typing import Callable

from tqdm import tqdm

from sim.errors import SimError
from sim.stage_timer import NO_TIMER

MAX_THREADS = 16


def default_threads() -> int:
    """Worker threads when none are asked for: one per CPU the process may use (at most 16)."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:                     # not Linux
        n = os.cpu_count() or 1
    return max(1, min(MAX_THREADS, n))


class FramePipeline:
    """``threads`` workers (0: inline), at most ``depth`` frames in flight (default ``2 threads + 1``)."""

    def __init__(self, threads: int | None = None, depth: int | None = None):
        threads = default_threads() if threads is None else int(threads)
        if threads < 0:
            raise SimError(f"frame pipeline: threads {threads}; must be >= 0")
        self.threads = threads
        self.depth = max(1, int(depth) if depth is not None else 2 * threads + 1)
        self._pool = ThreadPoolExecutor(threads, thread_name_prefix="frame") if threads else None
        self._pending: deque = deque()

    def submit(self, work: Callable[[], object], commit: Callable[[object], None]) -> None:
        """Run ``work()`` in a worker, then ``commit(result)`` on this thread after every earlier commit."""
        if self._pool is None:
            commit(work())
            return
        while len(self._pending) >= self.depth:
            self._commit_oldest()
        self._pending.append((self._pool.submit(work), commit))

    def _commit_oldest(self) -> None:
        future, commit = self._pending.popleft()
        commit(future.result())

    def drain(self) -> None:
        """Commit every frame submitted so far (in order)."""
        while self._pending:
            self._commit_oldest()

    def close(self) -> None:
        """Drop frames not started, wait for running ones; no further commit."""
        pending, self._pending = self._pending, deque()
        for future, _ in pending:
            future.cancel()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        for future, _ in pending:                  # collect worker exceptions so none is left unretrieved
            if not future.cancelled():
                future.exception()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        try:
            if exc_type is None:
                self.drain()
        finally:
            self.close()


class FrameLoop:
    """The frame loop of a generator (:mod:`sim.generate`, :mod:`sim.generate_traverse`): each frame's work in a
    :class:`FramePipeline` of ``threads`` workers, its ``commit`` on the caller's thread in submission order,
    followed by one progress tick (``tqdm`` bar ``desc``, ``total`` frames, from ``initial``; off unless
    ``progress``). Leaving the ``with`` block normally drains the pipeline, records the loop's elapsed and
    process CPU time on ``timer`` (:class:`sim.stage_timer.StageTimer`) as ``frame loop`` and
    ``frame loop CPU``, and closes the bar; an exception drops the frames not started (:meth:`FramePipeline.close`)."""

    def __init__(self, total: int, desc: str, threads: int | None = None, progress: bool = True, initial: int = 0,
                 timer=NO_TIMER, unit: str = "pair"):
        self.pipeline = FramePipeline(threads)
        self.timer = timer
        self.bar = tqdm(total=total, initial=initial, desc=desc, unit=unit, disable=not progress, dynamic_ncols=True)
        self._t0, self._c0 = time.perf_counter(), time.process_time()

    def submit(self, work: Callable[[], object], commit: Callable[[object], None]) -> None:
        """Queue ``work`` (a frame's files, on a worker); ``commit(result)`` and the progress tick follow in order."""
        def done(result):
            commit(result)
            self.bar.update(1)
        self.pipeline.submit(work, done)

    def __enter__(self) -> "FrameLoop":
        return self

    def __exit__(self, exc_type, exc, tb):
        self.pipeline.__exit__(exc_type, exc, tb)
        if exc_type is None:
            self.timer.add("frame loop", time.perf_counter() - self._t0)
            self.timer.add("frame loop CPU", time.process_time() - self._c0)
            self.bar.close()
