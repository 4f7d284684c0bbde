"""``klt-pnp``'s online disparity-offset estimate on one dataset, frame by frame (docs/estimators.md,
"`klt-pnp`: the disparity offset estimated online").

Runs ``klt-pnp`` through the product's frame loop (:func:`vo.estimators.runner.run_estimator`) and prints: the
CPU time per frame (``time.process_time``, image decoding included), the estimated and true path length, the
end drift (end-point difference over the true path, both anchored at the first pose), the median step / true
step ratio (overall and per half of the route), the keyframes' offset estimates (weighted mean, its standard
error from their spread, median, count) and the first frame the offset was applied.
``--fixed-offset PX`` replaces the estimate by one that applies ``PX`` from the first frame (a diagnosis: what
the route gives with that offset known in advance), injected through the estimator's ``offset`` collaborator.

Usage::

    python docs/studies/klt_pnp_offset.py DATASET [--opts JSON] [--max-frames N] [--fixed-offset PX]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from vo.dataset import open_dataset
from vo.estimators.disparity_offset import DisparityOffset, OffsetConfig
from vo.estimators.runner import run_estimator


class FixedOffset(DisparityOffset):
    """An offset known in advance: applied from the first landmark on, never re-estimated."""

    def __init__(self, delta_px: float, f_px: float, baseline_m: float):
        super().__init__(OffsetConfig(), f_px, baseline_m)
        self.delta_px = delta_px

    def _update(self) -> None:
        pass


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("--opts", default="{}", help="estimator options as JSON")
    ap.add_argument("--max-frames", type=int, default=None)
    ap.add_argument("--fixed-offset", type=float, default=None)
    a = ap.parse_args()
    ds = open_dataset(a.dataset)
    opts = json.loads(a.opts)
    if a.fixed_offset is not None:
        opts["offset"] = FixedOffset(a.fixed_offset, float(ds.rig.cameras[0].K[0, 0]), ds.rig.baseline)
    applied = []
    t0 = time.process_time()
    run = run_estimator("klt-pnp", ds, opts, progress=False, max_frames=a.max_frames,
                        on_frame=lambda frame, res, est: applied.append(est.offset.delta_px != 0.0))
    cpu = time.process_time() - t0
    n = len(run.frames)
    est = np.array([f.T_o_c0[:3, 3] for f in run.frames])
    gt = ds.groundtruth_cam0().T
    g = np.array([np.linalg.inv(gt[0]) @ gt[k] for k in range(n)])[:, :3, 3]
    se, sg = np.linalg.norm(np.diff(est, axis=0), axis=1), np.linalg.norm(np.diff(g, axis=0), axis=1)
    ratio, moving = se / np.maximum(sg, 1e-9), sg > 0.05
    h = (n - 1) // 2
    print(f"frames {n}  CPU {cpu / n * 1e3:.1f} ms/frame")
    drift = np.linalg.norm(est[-1] - g[-1]) / sg.sum() * 100
    print(f"path est {se.sum():.2f} m, true {sg.sum():.2f} m; drift {drift:.3f} %")
    print(f"step / true step median {np.median(ratio[moving]):.3f} (halves {np.median(ratio[:h][moving[:h]]):.3f} / "
          f"{np.median(ratio[h:][moving[h:]]):.3f})")
    fits = run.estimator.offset.fits
    if fits:
        d = np.array([f[0] for f in fits])
        w = 1.0 / np.array([max(f[1], 1e-6) for f in fits])
        m = float(np.sum(w * d) / np.sum(w))
        se_m = float(np.sqrt(np.sum(w * (d - m) ** 2) / np.sum(w) / max(len(d) - 1, 1)))
        print(f"offset estimate {m:.3f} px (standard error {se_m:.3f}, median {np.median(d):.3f}, "
              f"{len(d)} keyframes)")
    first = next((k for k, x in enumerate(applied) if x), None)
    print(f"offset applied {run.estimator.offset.delta_px:.3f} px, from frame {first}")


if __name__ == "__main__":
    main()
