"""CPU time per frame of ``klt-pnp`` on the first frames of a dataset (docs/estimators.md, "`klt-pnp`: the
disparity offset estimated online", Speed): frames decoded beforehand, OpenCV on one thread,
``time.process_time`` around the estimator's ``process`` calls only. Run with ``OMP_NUM_THREADS=1`` (scipy's
BLAS otherwise spreads small SVDs over threads, which on a loaded machine costs CPU time).

Usage::

    OMP_NUM_THREADS=1 python docs/studies/klt_pnp_cpu.py DATASET [N_FRAMES]
"""
from __future__ import annotations

import sys
import time

import cv2

from vo.dataset import open_dataset
from vo.estimators.registry import make_estimator


def main() -> None:
    cv2.setNumThreads(1)
    ds = open_dataset(sys.argv[1])
    frames = list(ds.frames(0, int(sys.argv[2]) if len(sys.argv) > 2 else 150))
    cv2.setRNGSeed(0)
    est = make_estimator("klt-pnp", ds.rig)
    t0 = time.process_time()
    for f in frames:
        est.process(f)
    print(f"klt-pnp CPU {(time.process_time() - t0) / len(frames) * 1e3:.2f} ms/frame over {len(frames)} frames")


if __name__ == "__main__":
    main()
