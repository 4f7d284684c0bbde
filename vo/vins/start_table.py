"""The start-up table of ``docs/vins.md``: when and how well ``vins`` initialises without truth, and what it
covers afterwards, per dataset.

``python -m vo.vins.start_table DATASET [DATASET ...] [--frames N] [--json OUT] [--opt key=value ...]``
runs ``vins`` (or ``--estimator NAME``) on each dataset's first ``N`` frames (default: all) and prints one row:
the frame and time (from the first frame) of the first initialisation, the distance travelled by then,
the alignment's scale and gravity errors against the truth at that initialisation (:class:`InitRecorder`,
injected into the estimator, not patched in), the re-initialisations, the frames covered (status ``ok`` or
``keyframe``: a pose was produced), the drift (end-point error / path, %) and the mean RPE over 10 m pairs
of the covered frames from the first initialisation on, aligned at that frame. Bad input: one ``error:``
line, exit 2.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from vo.eval.rpe import rpe
from vo.trajectory import Trajectory
from vo.vins.imu import GRAVITY
from vo.vins.initial import initialize

COVERED = ("ok", "keyframe")
RPE_M = 10.0


class InitRecorder:
    """An initializer (:func:`vo.vins.initial.initialize`'s signature) that records, for each successful
    start, the keyframe span and the errors against the dataset's truth ``gt`` (``T_w_c0`` Trajectory):
    scale error (least-squares scale of the SfM positions against the true ones, relative to the
    reference keyframe, minus 1) and the angle between the aligned and the true gravity (deg)."""

    def __init__(self, gt, inner=initialize):
        self.gt, self.inner = gt, inner
        self.k_of = {int(t): k for k, t in enumerate(gt.t_ns)}
        self.starts: list = []
        self.last_message = ""

    def __call__(self, stream, params, frames, T_i_c, config):
        r, msg = self.inner(stream, params, frames, T_i_c, config)
        self.last_message = msg
        if r is not None:
            ks = [self.k_of[int(f.t_ns)] for f in frames]
            T_c0_w = np.linalg.inv(self.gt.T[ks[r.ref]])
            p_true = (T_c0_w @ self.gt.T[ks])[:, :3, 3]
            g_true = T_c0_w[:3, :3] @ np.array([0.0, 0.0, -GRAVITY])
            ds = r.scale * np.sum(r.p_v_c * p_true) / np.sum(p_true ** 2) - 1
            dg = np.degrees(np.arccos(np.clip(r.g_v @ g_true / GRAVITY ** 2, -1, 1)))
            self.starts.append({"keyframes": [ks[0], ks[-1]], "scale_err_pct": float(ds * 100),
                                "gravity_err_deg": float(dg)})
        return r, msg


def run_one(path, n_frames=None, estimator: str = "vins", options=None) -> dict:
    """Row of the start table for the dataset at ``path`` (see the module docstring)."""
    from vo.dataset import open_dataset
    from vo.estimators.registry import make_estimator
    ds = open_dataset(path)
    gt = ds.groundtruth_cam0()
    rec = InitRecorder(gt)
    est = make_estimator(estimator, ds.rig, initializer=rec, **(options or {}))
    est.set_imu(ds.imu)
    est.set_dataset(ds)
    n = len(ds) if n_frames is None else min(int(n_frames), len(ds))
    status, T, events = [], [], []
    t0 = time.perf_counter()
    for k, fr in enumerate(ds.frames(0, n)):
        res = est.process(fr)
        status.append(res.status)
        T.append(res.T_o_c0)
        if res.message == "initialised" or (res.status == "reinit" and (k == 0 or status[-2] != "reinit")):
            events.append((k, res.status, res.message))
    wall = time.perf_counter() - t0
    t_ns = np.asarray(gt.t_ns[:n], np.int64)
    Tg = gt.T[:n]
    row = {"dataset": str(path), "frames": n, "route_m": float(np.sum(np.linalg.norm(np.diff(Tg[:, :3, 3], axis=0),
                                                                                   axis=1))),
           "wall_s": wall, "events": events, "starts": rec.starts,
           "covered": int(sum(s in COVERED for s in status))}
    first = next((k for k, s in enumerate(status) if s in COVERED), None)
    row["init_frame"] = first
    if first is None:
        row["last_message"] = rec.last_message
        return row
    row["init_time_s"] = float((t_ns[first] - t_ns[0]) * 1e-9)
    row["init_dist_m"] = float(np.sum(np.linalg.norm(np.diff(Tg[:first + 1, :3, 3], axis=0), axis=1)))
    row["reinits"] = sum(1 for e in events if e[1] == "reinit")
    idx = np.array([k for k in range(first, n) if status[k] in COVERED])
    if len(idx) < 2:
        return row
    Te = np.array(T)[idx]
    Tg_c = Tg[idx]
    Te = Tg_c[0] @ np.linalg.inv(Te[0]) @ Te
    g, e = Trajectory(t_ns[idx], Tg_c, "o", "c0"), Trajectory(t_ns[idx], Te, "o", "c0")
    row["path_m"] = float(g.path_length)
    row["drift_pct"] = float(np.linalg.norm(Te[-1, :3, 3] - Tg_c[-1, :3, 3]) / max(g.path_length, 1e-9) * 100)
    if g.path_length > 2 * RPE_M:
        row["rpe10m_mean_m"] = float(np.mean(rpe(g, e, RPE_M, "m", pairs_from="gt").t_err_m))
    return row


def format_row(r: dict) -> str:
    """One markdown table row."""
    name = r["dataset"].rstrip("/").split("/")[-1]
    if r["init_frame"] is None:
        return (f"| {name} | {r['frames']} | no initialisation | - | - | - | 0 | - | - | - | "
                f"last: {r.get('last_message', '')} |")
    s = r["starts"][0] if r["starts"] else {}
    f = (lambda key, fmt: format(r[key], fmt) if key in r else "-")
    return (f"| {name} | {r['frames']} | {r['init_frame']} / {r['init_time_s']:.1f} s / {r['init_dist_m']:.1f} m | "
            f"{s.get('scale_err_pct', float('nan')):+.2f} | {s.get('gravity_err_deg', float('nan')):.3f} | "
            f"{r['reinits']} | {r['covered']} | {f('path_m', '.0f')} | {f('drift_pct', '.2f')} | "
            f"{f('rpe10m_mean_m', '.3f')} | |")


HEADER = ("| dataset | frames | init: frame / time / distance | scale err % | gravity err deg | reinits | "
          "frames covered | path m after init | drift % | RPE 10 m mean m | note |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|")


def main(argv=None) -> int:
    from rigs.errors import TestbedError
    from rigs.typed_config import parse_value
    from vo.errors import EstimatorError
    args = list(sys.argv[1:] if argv is None else argv)
    paths, opts, n, out, est = [], {}, None, None, "vins"
    try:
        while args:
            a = args.pop(0)
            if a == "--frames":
                n = int(args.pop(0))
            elif a == "--json":
                out = args.pop(0)
            elif a == "--estimator":
                est = args.pop(0)
            elif a == "--opt":
                k, v = args.pop(0).split("=", 1)
                opts[k] = parse_value(v, k, EstimatorError)
            else:
                paths.append(a)
    except (IndexError, ValueError):
        print("usage: python -m vo.vins.start_table DATASET [...] [--frames N] [--json OUT] [--estimator NAME] "
              "[--opt key=value ...]", file=sys.stderr)
        return 2
    if not paths:
        print("usage: python -m vo.vins.start_table DATASET [...] [--frames N] [--json OUT]", file=sys.stderr)
        return 2
    print(HEADER, flush=True)
    rows = []
    try:
        for p in paths:
            r = run_one(p, n, est, opts)
            rows.append(r)
            print(format_row(r), flush=True)
    except TestbedError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if out:
        with open(out, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
