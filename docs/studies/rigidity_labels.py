"""What the rigidity test across frames (seed 001 eq. 2, ``vo.estimators.rigidity``) flags in ``klt-pnp``, by true label.

Runs ``klt-pnp`` with the test on (its ``rigidity_observer`` hook receives the PnP inliers it tested and its
verdict) on a dataset written with ``--segmentation`` and counts, over all frames, the tested landmarks on
moving actors and on the static world and the share of each that the test flagged; with ``--depth`` in the
dataset also those on depth edges (the 5x5 true-depth window is not one plane in inverse depth within 0.5 %,
the rule of docs/estimators.md "Cause of klt-pnp's remaining urban drift"). Prints the end drift too::

    vo-testbed generate --scenario urban-dynamic --segmentation [--depth] --seed N --duration 30 --out DATA
    python docs/studies/rigidity_labels.py DATA [--max-frames 300] [--opt 'rigidity={enabled: true, ...}']
"""
from __future__ import annotations

import argparse

import numpy as np
import yaml

from rigs.geometry import inv_T
from vo.dataset import open_dataset
from vo.errors import DatasetError
from vo.estimators.runner import run_estimator
from vo.vins.truth_segmentation import FeatureLabels


def _edge(depth: np.ndarray, px: np.ndarray, tol: float = 0.005) -> np.ndarray:
    """(M,) True where the 5x5 window of ``depth`` (H,W, m) around the rounded pixels is not one plane in inverse
    depth within ``tol`` (relative): a least-squares plane fit's largest residual."""
    h, w = depth.shape
    yy, xx = np.mgrid[-2:3, -2:3]
    A = np.c_[xx.ravel(), yy.ravel(), np.ones(25)]
    out = np.zeros(len(px), bool)
    for m, (u, v) in enumerate(np.round(px).astype(int)):
        if not (2 <= u < w - 2 and 2 <= v < h - 2):
            continue
        z = depth[v - 2:v + 3, u - 2:u + 3].ravel()
        if not np.all(np.isfinite(z)) or np.any(z <= 0):
            out[m] = True
            continue
        q = 1.0 / z
        r = q - A @ np.linalg.lstsq(A, q, rcond=None)[0]
        out[m] = np.max(np.abs(r)) > tol * q[12]
    return out


def run(dataset_dir: str, max_frames: int | None, options: dict) -> None:
    ds = open_dataset(dataset_dir)
    labels = FeatureLabels.of(ds)
    if labels is None:
        raise SystemExit(f"{dataset_dir}: no segmentation (generate with --segmentation)")
    try:
        ds.depth(0)
        has_depth = True
    except DatasetError:
        has_depth = False
    counts = {k: np.zeros(2, int) for k in ("moving", "static", "static_edge", "static_plane")}
    cur = {"k": 0, "T": None}

    def observe(px, kept):
        k = cur["k"]
        dyn = labels.dynamic(k, px)
        for name, sel in (("moving", dyn), ("static", ~dyn)):
            counts[name] += (int(sel.sum()), int((sel & ~kept).sum()))
        if has_depth:
            edge = _edge(np.asarray(ds.depth(k), float), px)
            for name, sel in (("static_edge", ~dyn & edge), ("static_plane", ~dyn & ~edge)):
                counts[name] += (int(sel.sum()), int((sel & ~kept).sum()))

    opts = {"rigidity": {"enabled": True}, **options, "rigidity_observer": observe}
    n = len(ds) if max_frames is None else min(max_frames, len(ds))

    def before(frame):
        cur["k"] = frame.index

    def after(frame, res, est):
        cur["T"] = res.T_o_c0.copy()

    run_estimator("klt-pnp", ds, opts, progress=False, max_frames=n, before_frame=before, on_frame=after)
    T_w_c = ds.groundtruth_cam0().T[:n]
    path = float(np.sum(np.linalg.norm(np.diff(T_w_c[:, :3, 3], axis=0), axis=1)))
    end = inv_T(T_w_c[0]) @ T_w_c[-1]
    print(f"frames {n}, path {path:.1f} m, end drift {100 * np.linalg.norm(cur['T'][:3, 3] - end[:3, 3]) / path:.2f} %")
    for name, (tested, flagged) in counts.items():
        if tested:
            print(f"{name:13s}: tested {tested:7d}, flagged {flagged:6d} ({100 * flagged / tested:.1f} %)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--max-frames", type=int)
    ap.add_argument("--opt", action="append", default=[], help="KEY=VALUE (YAML value)")
    a = ap.parse_args()
    run(a.dataset, a.max_frames, {kv.split("=", 1)[0]: yaml.safe_load(kv.split("=", 1)[1]) for kv in a.opt})


if __name__ == "__main__":
    main()
