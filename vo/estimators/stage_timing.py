"""Per-stage wall time of one frame: ``with timed(timings, "pnp"): ...`` adds the block's milliseconds to
``timings["pnp"]`` (the estimators' ``FrameResult.timings``)."""
from __future__ import annotations

import time
from contextlib import contextmanager


@contextmanager
def timed(timings: dict, key: str):
    """Add the wall time of the ``with`` block, in ms, to ``timings[key]`` (created at 0)."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings[key] = timings.get(key, 0.0) + (time.perf_counter() - t0) * 1e3
