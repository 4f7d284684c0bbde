"""A short LK search from the prediction (docs/estimators.md, "Cuts that change results, measured and not taken", D).

``klt-pnp``'s temporal LK starts at each landmark's predicted pixel (:mod:`vo.estimators.track_prediction`) and,
as seed 003's, searches the 4 pyramid levels from there. The cut measured here searches first on the finest ``K``
levels only (a 21 px window: a basin of about ``2^(K-1) x 10`` px) and searches the points that loses on all 4
levels from the same start, as the product does; the raw-image fallback and the ZNCC check are the product's. The
tracker is injected through ``klt-pnp``'s ``tracker`` collaborator; nothing of the product is patched.

Usage::

    python docs/studies/lk_short_search.py drift DATASET OUT --levels K     # `vo-testbed run`'s figures, the cut
    OMP_NUM_THREADS=1 taskset -c 0 python docs/studies/lk_short_search.py cpu DATASET --levels K [--frames 200]
    python docs/studies/lk_short_search.py moving DATASET [--frames 150]     # needs a dataset with segmentation

``cpu``: CPU ms per frame of ``process`` (``time.process_time``, OpenCV on one thread, frames decoded beforehand),
the product and the cut alternating, two rounds. ``moving``: how far the 1-level search from the prediction ends
from the product's 4-level result, and which of those tracks lie on moving actors (the true segmentation).
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace

import cv2
import numpy as np

from vo.dataset import open_dataset
from vo.errors import DatasetError, VoError
from vo.estimators.pnp import KltPnpEstimator
from vo.frontend.klt import KltConfig, KltTracker, track_fb
from vo.frontend.lk_normalized import lk_pyramids
from vo.frontend.patch_check import zncc_mask
from vo.pipeline import run_dataset
from vo.vins.truth_segmentation import FeatureLabels


def short_then_full(img0, img1, p0, config: KltConfig, pyramid, guess, levels: int) -> tuple:
    """:func:`track_fb` from ``guess`` (mirrored backward start) on the finest ``levels`` levels, then on all of
    them for the points that search loses; the ZNCC check once, on the result -> ``(p1 (N,2), ok (N,))``."""
    short = replace(config, levels=levels, raw_fallback=False, min_zncc=-1.0)
    p1, ok = track_fb(img0, img1, p0, short, lambda im: pyramid(im)[:levels], guess, mirror=True)
    lost = np.flatnonzero(~ok)
    if len(lost):
        p1[lost], ok[lost] = track_fb(img0, img1, p0[lost], replace(config, min_zncc=-1.0), pyramid,
                                      np.asarray(guess)[lost], mirror=True)
    return p1, zncc_mask(img0, img1, p0, p1, ok, config.win, config.min_zncc, config.zncc_affine)


class ShortSearchTracker(KltTracker):
    """:class:`KltTracker` whose LK from a prediction is :func:`short_then_full` (without one: the product's)."""

    def __init__(self, width: int, height: int, levels: int, config: KltConfig = KltConfig()):
        super().__init__(width, height, config)
        self.levels = levels

    def track(self, img, guess=None):
        if guess is None or self.image is None or len(self.pts) == 0:
            return super().track(img, guess)
        p1, ok = short_then_full(self.image, img, self.pts, self.config, self.pyramid, guess, self.levels)
        self.pts, self.ids, self.image = p1[ok], self.ids[ok], img
        return ok


def tracker_for(rig, levels: int) -> ShortSearchTracker:
    cam = rig.cameras[0]
    return ShortSearchTracker(cam.width, cam.height, levels)


def drift(dataset: str, out: str, levels: int) -> None:
    rig = open_dataset(dataset).rig
    _, ev = run_dataset(dataset, "klt-pnp", out, options={"tracker": tracker_for(rig, levels)}, progress=False)
    print(f"{dataset}: klt-pnp, short search on {levels} level(s): drift {ev.evaluation.drift.drift_ratio_pct:.3f} %")


def cpu(dataset: str, levels: int, n_frames: int) -> None:
    cv2.setNumThreads(1)
    ds = open_dataset(dataset)
    frames = list(ds.frames(0, n_frames))

    def run(tracker) -> float:
        cv2.setRNGSeed(0)
        est = KltPnpEstimator(ds.rig, tracker=tracker)
        t0 = time.process_time()
        for f in frames:
            est.process(f)
        return (time.process_time() - t0) / len(frames) * 1e3

    for r in range(2):
        a, b = run(None), run(tracker_for(ds.rig, levels))
        print(f"round {r}: product {a:.2f}, short search on {levels} level(s) {b:.2f} CPU ms per frame")


class ComparingTracker(KltTracker):
    """The product's :class:`KltTracker`; after each LK from a prediction it also runs the 1-level search from the
    same start on the points the product kept and records ``(frame, distance (M,) px, ok (M,), new pixels (M,2))``."""

    def __init__(self, width: int, height: int, config: KltConfig = KltConfig()):
        super().__init__(width, height, config)
        self.frame, self.rows = 0, []

    def track(self, img, guess=None):
        prev, pts = self.image, self.pts.copy()
        ok = super().track(img, guess)
        if guess is not None and prev is not None and ok.any():
            c = self.config
            p_s, ok_s = lk_pyramids(self.pyramid(prev)[:1], self.pyramid(img)[:1], pts[ok], c.win, c.lk_iters,
                                    c.lk_eps, np.asarray(guess)[ok])
            self.rows.append((self.frame, np.linalg.norm(p_s - self.pts, axis=1), ok_s, self.pts.copy()))
        return ok


def moving(dataset: str, n_frames: int) -> None:
    ds = open_dataset(dataset)
    labels = FeatureLabels.of(ds)
    if labels is None:
        raise DatasetError(f"{dataset}: no segmentation (generate with --segmentation)")
    cam = ds.rig.cameras[0]
    tracker = ComparingTracker(cam.width, cam.height)
    est = KltPnpEstimator(ds.rig, tracker=tracker)
    for k, frame in enumerate(ds.frames(0, n_frames)):
        tracker.frame = k
        est.process(frame)
    dist = np.concatenate([r[1] for r in tracker.rows])
    ok = np.concatenate([r[2] for r in tracker.rows])
    dyn = np.concatenate([labels.dynamic(k, px) for k, _, _, px in tracker.rows])
    print(f"{dataset}: {len(dist)} tracks over {n_frames} frames, {dyn.mean():.3f} of them on moving actors")
    for lo, hi in ((0.0, 0.5), (0.5, 5.0), (5.0, np.inf)):
        m = ok & (dist > lo) & (dist <= hi)
        share = dyn[m].mean() if m.any() else float("nan")
        print(f"  1-level search ends {lo}-{hi} px from the product's: {m.mean():.4f} of the tracks, "
              f"{share:.3f} moving")
    print(f"  1-level search fails: {(~ok).mean():.4f} of the tracks")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("drift", "cpu", "moving"))
    ap.add_argument("dataset")
    ap.add_argument("out", nargs="?")
    ap.add_argument("--levels", type=int, default=2)
    ap.add_argument("--frames", type=int, default=None)
    a = ap.parse_args()
    if a.mode == "drift" and a.out is None:
        ap.error("drift needs OUT, the run's output folder")
    try:
        if a.mode == "drift":
            drift(a.dataset, a.out, a.levels)
        elif a.mode == "cpu":
            cpu(a.dataset, a.levels, a.frames or 200)
        else:
            moving(a.dataset, a.frames or 150)
    except VoError as e:                                    # bad input: one line, exit code 2
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
