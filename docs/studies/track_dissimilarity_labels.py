"""Do depth-edge landmarks of ``klt-pnp`` show in their window's change since birth? Shi and Tomasi's feature monitoring.

Shi and Tomasi ("Good features to track", 1994) reject features whose window, warped affinely back onto the
window of the frame the feature was first seen in, no longer matches it: a corner formed by a near edge over a far
surface (a T-junction on an occlusion boundary) changes its window as the two layers slide past each other, which
no affine warp of one surface undoes, while a corner on one surface keeps an affine-warped window. This study
runs the product ``klt-pnp`` on a dataset written with ``--segmentation --depth``, keeps every landmark's birth
pixel and left image, and at age ``K`` (frames since birth) measures the ZNCC of the birth window against the
current window at the track, translation only and after the affine + gain/offset fit of
:func:`vo.frontend.patch_check.affine_zncc` (21x21), and how far that fit's centre lies from the track. Labels
at the birth pixel as in ``track_residual_labels.py`` (plane / edge / big-step edge, moving actors left out).
Prints ROC areas (Mann-Whitney) of edges against plane for ``1 - ZNCC`` and the centre distance::

    vo-testbed generate --scenario urban-dynamic --segmentation --depth --seed N --duration 30 --out DATA
    python docs/studies/track_dissimilarity_labels.py DATA [--max-frames 300] [--ages 2 4 8]
"""
from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np

from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
from vo.frontend.patch_check import affine_zncc, zncc
from vo.vins.truth_segmentation import FeatureLabels

from track_residual_labels import birth_labels, roc_area

WIN = 21


def record(ds, max_frames: int, ages: list[int]) -> dict:
    """Run ``klt-pnp``; -> {age: list of (class 0 plane / 1 edge / 2 big-step, zncc, affine zncc, centre dist)}."""
    labels = FeatureLabels.of(ds)
    cam = ds.rig.cameras[0]
    fb = float(cam.K[0, 0]) * float(np.linalg.norm(ds.rig.T_c0_c1[:3, 3]))
    birth: dict = {}                  # id -> (frame, pixel (2,), class or None for moving)
    images: dict = {}
    out = defaultdict(list)

    def after(frame, result, est):
        k = frame.index
        images[k] = frame.left
        for old in [j for j in images if j < k - max(ages)]:
            del images[old]
        ids, pts = est.tracker.ids, est.tracker.pts
        new = np.array([int(i) not in birth for i in ids], bool)
        if new.any():
            for i, p, d, e, b in zip(ids[new], pts[new], *birth_labels(ds, labels, fb, k, pts[new])):
                birth[int(i)] = (k, p.copy(), None if d else (2 if b else int(e)))
        for K in ages:
            sel = [j for j, i in enumerate(ids) if birth[int(i)][0] == k - K and birth[int(i)][2] is not None
                   and int(i) in est.landmarks]
            if not sel or (k - K) not in images:
                continue
            p0 = np.array([birth[int(ids[j])][1] for j in sel])
            p1 = pts[sel]
            z = zncc(images[k - K], frame.left, p0, p1, WIN)
            za, c, fitted = affine_zncc(images[k - K], frame.left, p0, p1, WIN)
            dist = np.where(fitted, np.linalg.norm(c - p1, axis=1), np.inf)
            for j, zi, zai, di in zip(sel, z, za, dist):
                out[K].append((birth[int(ids[j])][2], zi, zai, di))

    run_estimator("klt-pnp", ds, progress=False, max_frames=max_frames, on_frame=after)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--max-frames", type=int, default=300)
    ap.add_argument("--ages", type=int, nargs="+", default=[2, 4, 8])
    a = ap.parse_args()
    ds = open_dataset(a.dataset)
    out = record(ds, min(a.max_frames, len(ds)), a.ages)
    print("| age K | statistic | n plane / edge / big | ROC edge vs plane | ROC big vs plane | ROC small vs plane | "
          "median plane / small / big |")
    print("|---|---|---|---|---|---|---|")
    for K in a.ages:
        v = np.array(out[K], float)
        cls = v[:, 0]
        for name, s in (("1 - ZNCC", 1 - v[:, 1]), ("1 - affine ZNCC", 1 - v[:, 2]), ("affine centre - track, px", v[:, 3])):
            fin = np.isfinite(s)
            p, e, b, sm = (s[fin & m] for m in (cls == 0, cls >= 1, cls == 2, cls == 1))
            print(f"| {K} | {name} | {len(p)} / {len(e)} / {len(b)} | {roc_area(e, p):.3f} | {roc_area(b, p):.3f} | "
                  f"{roc_area(sm, p):.3f} | {np.median(p):.3f} / {np.median(sm):.3f} / {np.median(b):.3f} |", flush=True)


if __name__ == "__main__":
    main()
