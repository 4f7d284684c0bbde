"""Which moving objects does ``vins``'s window hold, and how fast do they move against the car?

    OPENBLAS_NUM_THREADS=1 python docs/studies/vins_dynamic_window.py D [--max-frames N] [--every 10] \\
        [--opt key=value ...]

``D``: an EuRoC dataset of ours; the columns on moving objects need one written with ``--segmentation``
(``segmentation_ids.csv``, ``actors.csv``; without it every feature counts as static).
Runs ``vins`` frame by frame (the product's estimator, default options unless ``--opt``) and prints, every
``--every`` frames after the first pose: the newest state's speed against the true one (m/s), the window's time
span (s), its landmarks, how many of them the current frame sees on
moving objects (true segmentation at the feature's pixel), the mean reprojection error (px, over the
observing window states) of the static and of the dynamic ones (mean / max / count above 3 px), the actors they lie on (``actor_id:count``), and
per such actor its speed along the car's direction of travel relative to the car (m/s; ``actors.csv``'s
positions differenced over 0.1 s against the true body velocity), its range (m) and the along-track error of the
emitted poses (aligned at the first pose, m). An actor moving with the car (relative speed near 0) looks like
a far static point; one moving towards it like a near one. Bad input: one ``error:`` line, exit 2.
"""
from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from gtsam.symbol_shorthand import V

from rigs.errors import TestbedError
from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.estimators.runner import run_estimator


def actor_tracks(root: Path) -> dict:
    """actor_id -> (t_ns (m,), p_w (m,3)) from ``actors.csv``."""
    a = np.genfromtxt(root / "actors.csv", delimiter=",", skip_header=1, usecols=(0, 1, 3, 4, 5, 6))
    return {int(i): (a[a[:, 1] == i, 0].astype(np.int64), a[a[:, 1] == i, 3:6]) for i in np.unique(a[:, 1])}


def seg_to_actor(root: Path) -> tuple:
    """(object id -> actor id array, moving flag array), object id = seg_id - 1."""
    rows = np.genfromtxt(root / "segmentation_ids.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    n = int(rows["seg_id"].max()) + 1
    actor, moving = np.full(n, -1, int), np.zeros(n, bool)
    actor[rows["seg_id"] - 1] = rows["actor_id"]
    moving[rows["seg_id"] - 1] = rows["moving"] != 0
    return actor, moving


def velocity_at(t_ns: np.ndarray, p: np.ndarray, t: int) -> np.ndarray:
    k = int(np.clip(np.searchsorted(t_ns, t), 1, len(t_ns) - 1))
    return (p[k] - p[k - 1]) / max((t_ns[k] - t_ns[k - 1]) * 1e-9, 1e-9)


def reprojection_px(w) -> dict:
    """track id -> mean reprojection error (px) of the window's landmark over the window states observing it."""
    out: dict = {}
    T_c_w = {st.k: np.linalg.inv(w.T_w_c(st)) for st in w.states}
    for st in w.states:
        for i, xy in zip(st.feats.ids.tolist(), st.feats.xy):
            if i in w.lm:
                p = T_c_w[st.k][:3, :3] @ w.landmark_w(i) + T_c_w[st.k][:3, 3]
                out.setdefault(i, []).append(w.fx * np.linalg.norm(p[:2] / p[2] - xy))
    return {i: float(np.mean(e)) for i, e in out.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--max-frames", type=int, default=None)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("--opt", action="append", default=[], metavar="KEY=VALUE")
    a = ap.parse_args(argv)
    try:
        opts = {}
        for kv in a.opt:
            k, v = kv.split("=", 1)
            opts[k] = parse_value(v, k, EstimatorError)
        ds = open_dataset(a.dataset)
        root = Path(a.dataset)
        seg = (root / "segmentation_ids.csv").is_file()
        actor_of, moving_obj = seg_to_actor(root) if seg else (np.full(1, -1), np.zeros(1, bool))
        tracks = actor_tracks(root) if seg else {}
        gt = ds.groundtruth_cam0()
        state = {"T0": None}

        def on_frame(fr, res, est):
            k = fr.index
            if res.status not in ("ok", "keyframe"):
                return
            if state["T0"] is None:
                state["T0"] = (gt.T[k] @ np.linalg.inv(res.T_o_c0))
            if (k - state.get("first", k)) % a.every:
                state.setdefault("first", k)
                return
            state.setdefault("first", k)
            w, feats = est.window, est.window.states[-1].feats
            if seg:
                ids_img, _ = ds.segmentation(k)
                h, wd = ids_img.shape[:2]
                r = np.clip(np.round(feats.px[:, 1]).astype(int), 0, h - 1)
                c = np.clip(np.round(feats.px[:, 0]).astype(int), 0, wd - 1)
                obj = ids_img[r, c]
            else:
                obj = np.zeros(len(feats.ids), int)
            in_win = np.array([int(i) in w.lm for i in feats.ids.tolist()], bool)
            obj = np.clip(obj.astype(int), 0, len(actor_of) - 1)
            dyn = moving_obj[obj] & in_win
            count = Counter(int(actor_of[o]) for o in obj[dyn])
            T_gt = gt.T[k]
            fwd = T_gt[:3, 2] / np.linalg.norm(T_gt[:3, 2])          # camera z = direction of travel
            t = int(gt.t_ns[k])
            v_car = (gt.T[min(k + 1, len(gt.t_ns) - 1), :3, 3] - gt.T[max(k - 1, 0), :3, 3]) / \
                ((gt.t_ns[min(k + 1, len(gt.t_ns) - 1)] - gt.t_ns[max(k - 1, 0)]) * 1e-9)
            parts = []
            for aid, c in count.most_common(4):
                if aid not in tracks:
                    continue
                ta, pa = tracks[aid]
                v_rel = (velocity_at(ta, pa, t) - v_car) @ fwd
                j = int(np.clip(np.searchsorted(ta, t), 0, len(ta) - 1))
                rng = np.linalg.norm(pa[j, :2] - T_gt[:2, 3])
                parts.append(f"{aid}:{c}({v_rel:+.1f} m/s, {rng:.0f} m)")
            err = reprojection_px(w)
            e_d = [err[int(i)] for i, d in zip(feats.ids.tolist(), dyn) if d and int(i) in err]
            e_s = [err[int(i)] for i, d, iw in zip(feats.ids.tolist(), dyn, in_win) if iw and not d and int(i) in err]
            q = (lambda e: f"{np.mean(e):5.2f}/{np.max(e):5.2f}/{np.sum(np.array(e) > 3):2d}" if e else "    -")
            v_est = float(np.linalg.norm(w.values.atVector(V(w.states[-1].k))))
            span = (w.states[-1].t_ns - w.states[0].t_ns) * 1e-9
            Te = state["T0"] @ res.T_o_c0
            along = (Te[:3, 3] - T_gt[:3, 3]) @ fwd
            print(f"{k:5d} {(t - int(gt.t_ns[0])) * 1e-9:6.1f} {v_est:6.2f} {np.linalg.norm(v_car):6.2f} "
                  f"{span:5.1f} {len(w.lm):4d} {int(in_win.sum()):4d} "
                  f"{int(dyn.sum()):4d} {along:+7.2f}  {q(e_s)}  {q(e_d)}  " + " ".join(parts), flush=True)

        print(f"{a.dataset} vins {' '.join(a.opt)}\nframe    t s  v est v true  span   lm  seen  dyn  along m  static px mean/max/>3  dynamic px  actor:landmarks(rel. speed, range)")
        run_estimator("vins", ds, opts, progress=False, max_frames=a.max_frames, with_truth=True, on_frame=on_frame)
    except (TestbedError, OSError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
