"""The start-up table of ``docs/vins.md``: when and how well ``vins`` initialises without truth, and what it
covers afterwards, per dataset.

``python docs/studies/vins_start_table.py DATASET [DATASET ...] [--frames N] [--json OUT] [--traj PREFIX] [--opt key=value ...]``
runs ``vins`` (or ``--estimator NAME``) on each dataset's first ``N`` frames (default: all) and prints one row:
the frame and time (from the first frame) of the first initialisation, the distance travelled by then,
the scale and gravity errors against the truth of the alignment that started the window (:class:`InitRecorder`,
injected into the estimator, not patched in) and of the window when it emits its first pose
(:func:`window_errors`; later than the alignment after a provisional start), the re-initialisations, the frames covered (status ``ok`` or
``keyframe``: a pose was produced), the drift (end-point error / path, %) and the mean RPE over 10 m pairs
of the covered frames from the first initialisation on, aligned at that frame; in the JSON also the CPU time
per frame (``time.process_time`` around ``process``) from the first pose on; ``--traj PREFIX`` saves each
dataset's per-frame statuses, poses and CPU times to ``PREFIX_<dataset name>.npz``. Bad input: one ``error:``
line, exit 2.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from rigs.errors import TestbedError
from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.estimators.runner import run_estimator
from vo.eval.rpe import rpe
from rigs.trajectory import Trajectory
from vo.vins.imu import GRAVITY
from vo.vins.vi_init import initialize

COVERED = ("ok", "keyframe")
RPE_M = 10.0


class InitRecorder:
    """An initializer (:func:`vo.vins.vi_init.initialize`'s signature) that records, for each successful
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


def window_errors(w, gt) -> dict:
    """The window against the truth: scale error (least-squares ratio of the states' distances from the oldest
    state, estimated vs true, minus 1, %) and the tilt of the newest camera (deg; yaw is unobservable)."""
    k_of = {int(t): k for k, t in enumerate(gt.t_ns)}
    T_e = np.array([w.T_w_c(st) for st in w.states])
    T_g = gt.T[[k_of[int(st.t_ns)] for st in w.states]]
    d_e, d_g = (np.linalg.norm(T[:, :3, 3] - T[0, :3, 3], axis=1) for T in (T_e, T_g))
    up_e, up_g = T_e[-1, :3, :3].T[:, 2], T_g[-1, :3, :3].T[:, 2]
    return {"window_scale_err_pct": float((np.sum(d_e * d_g) / np.sum(d_g ** 2) - 1) * 100),
            "window_tilt_deg": float(np.degrees(np.arccos(np.clip(up_e @ up_g, -1, 1))))}


def run_one(path, n_frames=None, estimator: str = "vins", options=None, traj_out=None) -> dict:
    """Row of the start table for the dataset at ``path`` (see the module docstring); with ``traj_out`` the
    per-frame statuses, emitted poses ``T_o_c0`` (n, 4, 4) and CPU seconds are saved there (``.npz``)."""
    ds = open_dataset(path)
    gt = ds.groundtruth_cam0()
    rec = InitRecorder(gt)
    n = len(ds) if n_frames is None else min(int(n_frames), len(ds))
    status, T, events, cpu = [], [], [], []
    at_pose, clock = {}, {}

    def before_frame(fr):
        clock["c0"] = time.process_time()

    def on_frame(fr, res, est):
        cpu.append(time.process_time() - clock["c0"])
        k = fr.index
        status.append(res.status)
        T.append(res.T_o_c0)
        if res.status in ("init", "reinit") and res.message and not res.message.startswith("collecting"):
            at_pose["last_message"] = res.message
        if "errors" not in at_pose and res.status in COVERED:
            at_pose["errors"] = window_errors(est.window, gt)
            at_pose["start"] = len(rec.starts) - 1       # the alignment the first pose came from
        if (res.message == "initialised" or res.message.startswith("scale not confirmed")
                or (res.status == "reinit" and (k == 0 or status[-2] != "reinit"))):
            events.append((k, res.status, res.message))

    t0 = time.perf_counter()
    run_estimator(estimator, ds, {**(options or {}), "initializer": rec}, progress=False, max_frames=n,
                  with_truth=True, before_frame=before_frame, on_frame=on_frame)
    wall = time.perf_counter() - t0
    if traj_out:
        np.savez_compressed(traj_out, status=np.array(status), T_o_c0=np.array(T), cpu_s=np.array(cpu),
                            t_ns=np.asarray(gt.t_ns[:len(status)], np.int64))
    at_first_pose = at_pose.get("errors")
    t_ns = np.asarray(gt.t_ns[:n], np.int64)
    Tg = gt.T[:n]
    row = {"dataset": str(path), "frames": n, "route_m": float(np.sum(np.linalg.norm(np.diff(Tg[:, :3, 3], axis=0),
                                                                                   axis=1))),
           "wall_s": wall, "events": events, "starts": rec.starts,
           "covered": int(sum(s in COVERED for s in status))}
    first = next((k for k, s in enumerate(status) if s in COVERED), None)
    row["init_frame"] = first
    row["refused_by_window"] = sum(1 for e in events if e[2].startswith("scale not confirmed"))
    if first is None:
        row["last_message"] = at_pose.get("last_message", rec.last_message)
        return row
    row["init_time_s"] = float((t_ns[first] - t_ns[0]) * 1e-9)
    row["init_dist_m"] = float(np.sum(np.linalg.norm(np.diff(Tg[:first + 1, :3, 3], axis=0), axis=1)))
    row.update({k: v for k, v in at_first_pose.items() if k != "start"})
    row["first_start"] = rec.starts[at_pose["start"]] if at_pose["start"] >= 0 else {}
    row["reinits"] = sum(1 for e in events if e[1] == "reinit")
    cpu_after = np.array(cpu[first:]) * 1e3
    row["cpu_ms_per_frame_after_init"] = {"mean": float(cpu_after.mean()), "p90": float(np.percentile(cpu_after, 90))}
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
    s = r.get("first_start", {})
    f = (lambda key, fmt: format(r[key], fmt) if key in r else "-")
    return (f"| {name} | {r['frames']} | {r['init_frame']} / {r['init_time_s']:.1f} s / {r['init_dist_m']:.1f} m | "
            f"{s.get('scale_err_pct', float('nan')):+.2f} / {r['window_scale_err_pct']:+.2f} | "
            f"{s.get('gravity_err_deg', float('nan')):.3f} / {r['window_tilt_deg']:.3f} | "
            f"{r['reinits']} | {r['covered']} | {f('path_m', '.0f')} | {f('drift_pct', '.2f')} | "
            f"{f('rpe10m_mean_m', '.3f')} | |")


HEADER = ("| dataset | frames | first pose: frame / time / distance | scale err % (alignment / window) | "
          "gravity err deg (alignment / window tilt) | reinits | "
          "frames covered | path m after init | drift % | RPE 10 m mean m | note |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|")


def main(argv=None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    paths, opts, n, out, est, traj = [], {}, None, None, "vins", None
    try:
        while args:
            a = args.pop(0)
            if a == "--frames":
                n = int(args.pop(0))
            elif a == "--json":
                out = args.pop(0)
            elif a == "--traj":
                traj = args.pop(0)
            elif a == "--estimator":
                est = args.pop(0)
            elif a == "--opt":
                k, v = args.pop(0).split("=", 1)
                opts[k] = parse_value(v, k, EstimatorError)
            else:
                paths.append(a)
    except (IndexError, ValueError):
        print("usage: python docs/studies/vins_start_table.py DATASET [...] [--frames N] [--json OUT] [--estimator NAME] "
              "[--opt key=value ...]", file=sys.stderr)
        return 2
    if not paths:
        print("usage: python docs/studies/vins_start_table.py DATASET [...] [--frames N] [--json OUT]", file=sys.stderr)
        return 2
    print(HEADER, flush=True)
    rows = []
    try:
        for p in paths:
            r = run_one(p, n, est, opts, traj and f"{traj}_{p.rstrip('/').split('/')[-1]}.npz")
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
