"""Progress of a run over frames: a bar on a terminal, a plain line per step elsewhere (CI logs).

A bar redrawn with carriage returns is noise in a log file, and no bar at all is minutes of silence;
so when the stream is not a terminal, :func:`progress_iter` prints one line each time another
``step_pct`` percent of the frames is done (and at the end), e.g. ``klt-pnp: 31/61 frames (50 %), 4.2 s``.
"""
from __future__ import annotations

import sys
import time
from typing import Iterable, Iterator, Optional, TextIO

DEFAULT_STEP_PCT = 10


def progress_iter(it: Iterable, total: int, enabled: bool, desc: str, stream: Optional[TextIO] = None,
                  step_pct: int = DEFAULT_STEP_PCT) -> Iterable:
    """``it`` wrapped to report progress on ``stream`` (default stderr); ``total`` items expected.
    Disabled -> ``it`` itself. A terminal gets a tqdm bar; anything else :func:`progress_lines`."""
    if not enabled:
        return it
    stream = sys.stderr if stream is None else stream
    if _isatty(stream):
        from tqdm import tqdm
        return tqdm(it, total=total, desc=desc, unit="frame", file=stream)
    return progress_lines(it, total, desc, stream, step_pct)


def progress_lines(it: Iterable, total: int, desc: str, stream: TextIO, step_pct: int = DEFAULT_STEP_PCT
                   ) -> Iterator:
    """Yield the items of ``it``; after the item that completes another ``step_pct`` % of ``total`` (and
    after the last item) print ``desc: k/total frames (p %), t s`` on ``stream``, flushed."""
    if not 0 < step_pct <= 100:
        raise ValueError(f"step_pct: must be in (0, 100], got {step_pct!r}")
    t0, next_pct, k = time.perf_counter(), step_pct, 0
    for k, item in enumerate(it, 1):
        yield item
        pct = 100 * k / total if total else 100
        if pct >= next_pct or k == total:
            print(f"{desc}: {k}/{total} frames ({int(pct)} %), {time.perf_counter() - t0:.1f} s",
                  file=stream, flush=True)
            next_pct = (int(pct) // step_pct + 1) * step_pct


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):       # closed or not a file
        return False
