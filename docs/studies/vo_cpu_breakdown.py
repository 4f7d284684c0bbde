"""CPU time per frame of a stereo estimator and its split between OpenCV's compiled calls and the rest
(docs/estimators.md, "Speed": "Where a frame's time goes"). Frames decoded beforehand, OpenCV on one thread,
``time.process_time`` (CPU time, so a loaded machine inflates it less than wall time).

Two runs of the same frames: a plain one (the CPU ms per frame) and one under cProfile with the CPU timer,
whose built-in OpenCV calls (``calcOpticalFlowPyrLK``, ``findEssentialMat``, ``blur``, ...) are listed with
their share of the profiled time; the profiler's own overhead falls on the Python calls, so the compiled
share it prints is a lower bound.

Usage::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python docs/studies/vo_cpu_breakdown.py DATASET ESTIMATOR [N_FRAMES]
"""
from __future__ import annotations

import cProfile
import pstats
import sys
import time

import cv2

from vo.dataset import open_dataset
from vo.estimators.registry import make_estimator


def run(ds, name: str, frames: list, profile: cProfile.Profile | None = None) -> float:
    """CPU seconds of ``name``'s ``process`` over ``frames`` (a fresh estimator, OpenCV's RNG seeded)."""
    cv2.setRNGSeed(0)
    est = make_estimator(name, ds.rig)
    if profile is not None:
        profile.enable()
    t0 = time.process_time()
    for f in frames:
        est.process(f)
    dt = time.process_time() - t0
    if profile is not None:
        profile.disable()
    return dt


def main() -> None:
    cv2.setNumThreads(1)
    ds = open_dataset(sys.argv[1])
    name = sys.argv[2]
    frames = list(ds.frames(0, int(sys.argv[3]) if len(sys.argv) > 3 else 150))
    n = len(frames)
    plain = run(ds, name, frames)
    prof = cProfile.Profile(time.process_time)
    profiled = run(ds, name, frames, prof)
    stats = pstats.Stats(prof).stats                  # (file, line, function) -> (cc, nc, tottime, cumtime, callers)
    opencv = sorted(((v[2], k[2][1:-1], v[1]) for k, v in stats.items()       # OpenCV's: "<name>" without a module
                     if k[0] == "~" and k[2][1:-1].isidentifier()), reverse=True)
    print(f"{name}: {n} frames, CPU {plain / n * 1e3:.2f} ms/frame (profiled {profiled / n * 1e3:.2f})")
    total = 0.0
    for t, f, c in opencv[:8]:
        total += t
        print(f"  {f:28s} {c / n:6.2f} calls/frame {t / n * 1e3:6.2f} ms/frame {100 * t / profiled:5.1f} %")
    print(f"  these OpenCV calls: {total / n * 1e3:.2f} ms/frame, {100 * total / profiled:.1f} % of the profiled time")


if __name__ == "__main__":
    main()
