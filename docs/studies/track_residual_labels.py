"""Do depth-edge landmarks show a growing reprojection residual in ``klt-pnp``? Separation by true label.

A landmark born on an occlusion boundary (a T-junction: the corner is formed by a near edge over a far
surface) is not a fixed 3-D point: as the camera moves, the corner the KLT track follows slides along the
far surface, and its stereo depth lies between the two sides. Against its fixed landmark (birth stereo
point) and the estimated pose its reprojection residual should then grow with the track's age in one
direction, where a rigid point's stays noise. This study runs the product ``klt-pnp`` (no truth in the
estimator) on a dataset written with ``--segmentation --depth`` and, after each frame, records for every
tracked landmark its residual ``r(a) = track pixel - projection of the landmark at the frame's pose`` by age
``a`` (frames since birth). Labels from the truth at the birth pixel: moving actor (left out), "edge" (the
5x5 true-depth window is not one plane in inverse depth within 0.5 %, ``local_depth``'s rule, the ablation's
in docs/estimators.md), "big-step edge" (that window spans >= 3 px of disparity), "plane" (the rest).

Statistics of the landmarks that reach age ``K`` (a label-free test could use each of them at age K):
``|r(K)|`` (px), ``|mean r(1..K)|``, the residual along the parallax direction (the image direction in which a
change of the landmark's depth along its birth ray moves its projection; Jacobian ``J``, px per unit relative
depth) divided by its expected sigma from the stereo disparity noise and the track noise ("parallax chi": depth
from motion against depth from stereo), the residual across it, the relative depth error ``|r . J| / |J|^2`` where
``|J| > 50`` px, the least-squares slope ``|sum a r(a) / sum a^2|`` (px per frame), and the
growth of ``|r|`` relative to the frame's median ``|r|`` of landmarks of the same age (a pose error shared by
all landmarks cancels); and the mean signed residual along the parallax direction per class (the systematic part,
``J`` points where the projection goes when the landmark moves farther along its birth ray, so a positive mean
says the tracks move as if their points were farther than their stereo depth). Prints ROC areas (Mann-Whitney)
of all / big-step / small-step edges against plane, and the share of the edges above the plane's 90 % quantile::

    vo-testbed generate --scenario urban-dynamic --segmentation --depth --seed N --duration 30 --out DATA
    python docs/studies/track_residual_labels.py DATA [--max-frames 300] [--ages 3 5 8] [--opt KEY=VALUE]
"""
from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np
import yaml
from scipy.stats import rankdata

from rigs.geometry import inv_T, transform_points
from rigs.geometry.pinhole import project
from sim.app.validation.exact_points import local_depth
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
from vo.vins.truth_segmentation import FeatureLabels


def disparity_step(depth: np.ndarray, px: np.ndarray, fb: float) -> np.ndarray:
    """(N,) disparity span (px; inf with sky) of the 5x5 true-depth window around the rounded pixels."""
    h, w = depth.shape
    ij = np.clip(np.round(px).astype(int), 2, [w - 3, h - 3])
    win = np.stack([depth[ij[:, 1] + j, ij[:, 0] + i] for i in range(-2, 3) for j in range(-2, 3)], 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(np.isfinite(win) & (win > 0), fb / win, 0.0)
    return d.max(axis=1) - d.min(axis=1)


def birth_labels(ds, labels, fb: float, k: int, px: np.ndarray) -> tuple:
    """Truth labels of landmarks born at pixels ``px`` (N,2) of frame ``k`` -> ``(moving, edge, big_step)`` (N,) bool:
    on a moving actor (``labels``: :class:`FeatureLabels` or None), on a depth edge (``local_depth``'s 0.5 % plane
    rule fails), and an edge whose 5x5 window spans >= 3 px of disparity."""
    depth = np.asarray(ds.depth(k), float)
    _, plane = local_depth(depth, px)
    step = disparity_step(depth, px, fb)
    moving = labels.dynamic(k, px) if labels is not None else np.zeros(len(px), bool)
    edge = ~np.asarray(plane, bool)
    return np.asarray(moving, bool), edge, edge & (step >= 3.0)


def roc_area(pos: np.ndarray, neg: np.ndarray) -> float:
    """P(statistic of a positive > that of a negative) (ties count half)."""
    if not len(pos) or not len(neg):
        return float("nan")
    r = rankdata(np.r_[pos, neg])
    return float((r[:len(pos)].sum() - len(pos) * (len(pos) + 1) / 2) / (len(pos) * len(neg)))


EPS = 0.01            # relative depth step of the parallax Jacobian
SIGMA_D_PX = 0.1      # stereo disparity sigma (px), the measured robust std (docs/estimators.md)
SIGMA_PX = 0.35       # KLT track sigma per axis (px), likewise


def record(ds, max_frames: int, options: dict):
    """Run ``klt-pnp``; -> (labels {id: (dyn, edge, big)}, residuals {id: {age: r (2,)}}, median |r| by (k, age))."""
    labels = FeatureLabels.of(ds)
    cam = ds.rig.cameras[0]
    fb = float(cam.K[0, 0]) * float(np.linalg.norm(ds.rig.T_c0_c1[:3, 3]))
    born, lab, res = {}, {}, defaultdict(dict)
    med = {}

    def after(frame, result, est):
        k = frame.index
        ids, pts = est.tracker.ids, est.tracker.pts
        have = np.array([int(i) in est.landmarks for i in ids], bool)
        ids, pts = ids[have], pts[have]
        new = np.array([int(i) not in born for i in ids], bool)
        if new.any():
            for i, d, e, b in zip(ids[new], *birth_labels(ds, labels, fb, k, pts[new])):
                born[int(i)] = k
                lab[int(i)] = (bool(d), bool(e), bool(b))
        if result.pose_class != "ok" or not (~new).any():
            return
        old = ids[~new]
        p_o = np.array([est.landmarks[int(i)] for i in old])
        p_c = transform_points(inv_T(est.T_o_c0), p_o)
        uv = project(p_c, cam.K, cam.dist)
        r = pts[~new] - uv
        c_birth = np.array([est.near[int(i)][1] for i in old])       # the birth camera's centre, odometry frame
        p_far = c_birth + (p_o - c_birth) * (1.0 + EPS)               # the landmark 1 % farther along its birth ray
        J = (project(transform_points(inv_T(est.T_o_c0), p_far), cam.K, cam.dist) - uv) / EPS
        sig_rel = SIGMA_D_PX * np.linalg.norm(p_o - c_birth, axis=1) / fb   # relative depth sigma of the stereo point
        by_age = defaultdict(list)
        for i, ri, ji, si in zip(old, r, J, sig_rel):
            a = k - born[int(i)]
            res[int(i)][a] = (ri, ji, si)
            by_age[a].append(float(np.hypot(*ri)))
        for a, v in by_age.items():
            med[(k, a)] = float(np.median(v))

    run_estimator("klt-pnp", ds, options, progress=False, max_frames=max_frames, on_frame=after)
    return born, lab, res, med


def statistics(born, lab, res, med, K: int) -> dict:
    """-> {name: (values (M,), label (M,) 0 plane / 1 edge / 2 big-step edge)} over static landmarks reaching age K."""
    out = defaultdict(list)
    cls = []
    for i, rs in res.items():
        if lab[i][0] or not all(a in rs for a in range(1, K + 1)):
            continue
        R = np.array([rs[a][0] for a in range(1, K + 1)])
        a = np.arange(1, K + 1, dtype=float)
        r, J, sig = rs[K]
        j = np.hypot(*J)
        u = J / max(j, 1e-9)
        out["|r(K)|"].append(np.hypot(*R[-1]))
        out["parallax chi"].append(abs(r @ u) / np.hypot(j * sig, SIGMA_PX))
        out["signed r along parallax"].append(r @ u)
        out["|r across parallax|"].append(abs(r[0] * u[1] - r[1] * u[0]))
        out["|rel depth err| (J > 50 px)"].append(abs(r @ u) / j if j > 50 else np.nan)
        out["|mean r(1..K)|"].append(np.hypot(*R.mean(0)))
        out["|slope|"].append(np.hypot(*(a @ R / (a @ a))))
        out["|r(K)| / median"].append(np.hypot(*R[-1]) / max(med[(born[i] + K, K)], 1e-3))
        cls.append(2 if lab[i][2] else int(lab[i][1]))
    return {n: np.array(v) for n, v in out.items()}, np.array(cls)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--max-frames", type=int, default=300)
    ap.add_argument("--ages", type=int, nargs="+", default=[3, 5, 8])
    ap.add_argument("--opt", action="append", default=[], help="estimator option KEY=VALUE (YAML value)")
    a = ap.parse_args()
    options = {kv.split("=", 1)[0]: yaml.safe_load(kv.split("=", 1)[1]) for kv in a.opt}
    ds = open_dataset(a.dataset)
    n = min(a.max_frames, len(ds))
    born, lab, res, med = record(ds, n, options)
    static = [i for i in lab if not lab[i][0]]
    print(f"{a.dataset}, frames 0-{n - 1}: {len(lab)} landmarks, {len(static)} static, "
          f"{sum(lab[i][1] for i in static)} on depth edges ({sum(lab[i][2] for i in static)} big-step)")
    print("| age K | statistic | n plane / edge / big | ROC edge vs plane | ROC big vs plane | ROC small vs plane | "
          "median plane / edge / big | removed at plane's 90 % quantile: edge / big |")
    print("|---|---|---|---|---|---|---|---|")
    for K in a.ages:
        stats, cls = statistics(born, lab, res, med, K)
        for name, v in stats.items():
            if name.startswith("signed"):
                print(f"| {K} | {name}: mean +- s.e. px | " + " / ".join(
                    f"{np.mean(v[c]):+.3f} +- {np.std(v[c]) / np.sqrt(max(len(v[c]), 1)):.3f}" for c in
                    (cls == 0, cls == 1, cls == 2)) + " (plane / small-step edge / big-step edge) | | | | | |")
                continue
            fin = np.isfinite(v)
            p, e, b = v[fin & (cls == 0)], v[fin & (cls >= 1)], v[fin & (cls == 2)]
            q = np.quantile(p, 0.9) if len(p) else np.nan
            print(f"| {K} | {name} | {len(p)} / {len(e)} / {len(b)} | {roc_area(e, p):.3f} | {roc_area(b, p):.3f} | "
                  f"{roc_area(v[fin & (cls == 1)], p):.3f} | "
                  f"{np.median(p):.2f} / {np.median(e):.2f} / {np.median(b):.2f} | "
                  f"{100 * np.mean(e > q):.0f} % / {100 * np.mean(b > q):.0f} % |", flush=True)


if __name__ == "__main__":
    main()
