"""How long do the `vins` front-end's tracks live, and where do they end? Static and dynamic features apart.

Runs :class:`vo.vins.feature_tracker.KltFrontend` (the estimator's front-end, VINS-Mono's settings) over the first
FRAMES left images of a dataset written with ``--segmentation`` and, for every track that ends, records its
age (N, the count eq. 26 uses) and whether its last position lies within ``--border`` px of the image edge
(the forward flow carries it out). Labels from the true segmentation (:class:`vo.vins.truth_segmentation.FeatureLabels`)
at the track's last frame. Prints, per label: tracks ended, median / 90th percentile age, share ending at the
border, and the share of feature-frames with N < 10 (the paper's outlier rule, as the tables count it)::

    vo-testbed generate --scenario urban-dynamic --duration 25 --set imu=euroc-adis16448 --set seed=S \\
        --segmentation --out D10
    vo-testbed generate --scenario urban-dynamic --duration 40 --set imu=euroc-adis16448 --set seed=S \\
        --set motion.cruise_speed_mps=5 --segmentation --out D5
    python docs/studies/vins_track_life.py D10 D5 [--frames 251] [--border 20]
"""
from __future__ import annotations

import argparse

import numpy as np

from vo.dataset import open_dataset
from vo.vins.feature_tracker import KltFrontend
from vo.vins.truth_segmentation import FeatureLabels


def track_life(path: str, frames: int, border: float) -> dict:
    """``{label: (ages (n,), at_border (n,) bool, counts (m,))}`` for ``static`` and ``dynamic``."""
    ds = open_dataset(path)
    labels = FeatureLabels(ds)
    fe = KltFrontend(ds.rig.cameras[0])
    w, h = fe.size
    out = {k: ([], [], []) for k in ("static", "dynamic")}
    last = None
    for k in range(min(frames, len(ds))):
        fr = fe.track(ds.frame(k).left, 0)
        dyn = labels.dynamic(k, fr.px)
        for c, d in zip(fr.count, dyn):
            out["dynamic" if d else "static"][2].append(c)
        if last is not None:
            gone = ~np.isin(last[0], fr.ids)
            px, cnt, dy = last[1][gone], last[2][gone], last[3][gone]
            edge = (px[:, 0] < border) | (px[:, 1] < border) | (px[:, 0] > w - 1 - border) | (px[:, 1] > h - 1 - border)
            for c, e, d in zip(cnt, edge, dy):
                rec = out["dynamic" if d else "static"]
                rec[0].append(c)
                rec[1].append(e)
        last = (fr.ids, fr.px, fr.count, dyn)
    return {k: tuple(np.asarray(x) for x in v) for k, v in out.items()}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--frames", type=int, default=251)
    ap.add_argument("--border", type=float, default=20.0)
    a = ap.parse_args(argv)
    print("dataset | label | tracks ended | age median / p90 | ended at the border % | feature-frames N<10 %")
    for path in a.datasets:
        for label, (ages, edge, counts) in track_life(path, a.frames, a.border).items():
            if len(ages) == 0:
                continue
            print(f"{path} | {label} | {len(ages)} | {np.median(ages):.0f} / {np.percentile(ages, 90):.0f} | "
                  f"{100 * edge.mean():.1f} | {100 * (counts < 10).mean():.1f}")


if __name__ == "__main__":
    main()
