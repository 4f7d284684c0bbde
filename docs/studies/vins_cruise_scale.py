"""Where does ``vins``'s scale go at cruise? Per-keyframe biases, body velocity and scale against the truth.

    OPENBLAS_NUM_THREADS=1 python docs/studies/vins_cruise_scale.py D [--max-frames 450] [--opt key=value ...] \\
        [--estimator vins] [--every 5] [--npz OUT.npz] [--exact-tracks PX [--seed S]] [--flow-back PX] \\
        [--exclude-below V]

Runs the estimator on the first ``--max-frames`` frames of the EuRoC dataset ``D`` (ours: the true IMU biases
and velocities are the bias and velocity columns of ``mav0/state_groundtruth_estimate0/data.csv``) and, at
every keyframe after the initialisation, logs the newest window state against the truth:

* ``dba`` accelerometer bias error (estimate - truth, IMU axes, mm/s^2) and ``|dbg|`` gyro bias error (mrad/s);
* ``dg_x`` the forward (IMU x) component of gravity in the estimated body frame minus the true one
  (``9.81 * tilt``, mm/s^2; a pitch error the accelerometer sees as a forward specific force);
* ``e_fwd = dg_x - dba_x``: the forward acceleration error the window integrates at constant velocity
  (``a_w = R (f - b_a) + g``, so in the body frame ``R^T a = f - b_a + R^T g``);
* ``v_ratio`` estimated / true forward body velocity, ``sc10`` the 10-frame scale error of the emitted poses
  (estimated / true 10-frame path length - 1, the figure of ``vins_urban_tables.py --plot``) and ``along``
  the along-track position error of the emitted poses aligned at the first non-``init`` frame (m), ``sig_al``
  the estimator's own standard deviation along the track (``FrameResult.cov``, m).

``--exact-tracks PX`` (a dataset with depth: ``generate --depth``) separates the front-end from the back-end: the
KLT front-end still decides which tracks exist, but the back-end gets the exact projections (true poses) of the
3-D point seen at each track's first detection (rendered depth, ``sim.app.validation.exact_points``; tracks
starting at a depth edge are dropped), plus iid Gaussian noise of PX pixels (seeded generator, ``--seed``).

``--flow-back PX`` adds VINS-Fusion's reverse check to the KLT front-end: each track is also tracked back
from the new image to the previous one (starting at its old position) and dropped when it returns more than
PX pixels away (:class:`FlowBackKlt`).

``--exclude-below V`` keeps the front-end's features above image row V (no detection below it, tracks
dropped when they move below it): the road surface and the roadside objects at short range, whose image
motion at car speed is largest.

Prints a row every ``--every`` s of data and a summary per cruise leg (consecutive keyframes at true speed
> 9 m/s): the change of the forward velocity error against the integral of ``e_fwd`` (the mechanism: they
agree when the scale follows the velocity), its parts, and the bias random walks the IMU model allows over
the leg (``acc_w * sqrt(T)``, ``gyr_w * sqrt(T)``).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
from gtsam.symbol_shorthand import B, V, X

from rigs.errors import TestbedError
from rigs.geometry import R_from_quat_wxyz
from rigs.typed_config import parse_value
from sim.app.validation.exact_points import backproject, local_depth, project
from vo.dataset import open_dataset
from vo.dataset.csvio import read_numeric_csv
from vo.estimators.runner import run_estimator
from vo.vins.feature_tracker import KltFrontend
from vo.vins.imu import GRAVITY

CRUISE_MPS = 9.0
DELTA = 10            # frames of the scale error (1 s at 10 Hz)
E_Z = np.array([0.0, 0.0, 1.0])


class TrueStates:
    """IMU-rate truth of an EuRoC dataset: ``R_w_i``, ``v_w``, gyro and accelerometer biases."""

    def __init__(self, dataset_path: Path):
        path = Path(dataset_path) / "mav0" / "state_groundtruth_estimate0" / "data.csv"
        t, v = read_numeric_csv(path, 16, "ground truth with velocity and biases")
        self.t_ns, self.R_w_i, self.v_w = t, R_from_quat_wxyz(v[:, 3:7]), v[:, 7:10]
        self.b_g, self.b_a = v[:, 10:13], v[:, 13:16]

    def at(self, t_ns: int) -> int:
        k = int(np.searchsorted(self.t_ns, t_ns))
        if k >= len(self.t_ns) or self.t_ns[k] != t_ns:
            k = int(np.clip(k, 0, len(self.t_ns) - 1))      # the next sample (ours: frame times are IMU times)
        return k


def keyframe_record(est, truth: TrueStates) -> dict:
    """Newest window state of ``est`` against the truth at its time (see the module doc for the names)."""
    w = est.window
    st = w.states[-1]
    k = truth.at(st.t_ns)
    R_e = w.values.atPose3(X(st.k)).rotation().matrix()
    R_g = truth.R_w_i[k]
    bias = w.values.atConstantBias(B(st.k))
    v_b_e, v_b_g = R_e.T @ w.values.atVector(V(st.k)), R_g.T @ truth.v_w[k]
    dg = -GRAVITY * (R_e.T @ E_Z - R_g.T @ E_Z)       # gravity [0, 0, -g] seen in each body frame
    dba = bias.accelerometer() - truth.b_a[k]
    return dict(t_ns=st.t_ns, dba=dba, dbg=bias.gyroscope() - truth.b_g[k], dg=dg, e_fwd=dg[0] - dba[0],
                v_fwd_e=v_b_e[0], v_fwd_g=v_b_g[0], speed=float(np.linalg.norm(truth.v_w[k])),
                tilt_deg=float(np.degrees(np.arccos(np.clip(R_e[2] @ R_g[2], -1, 1)))))


def emitted_errors(T_est: np.ndarray, ok: np.ndarray, T_gt: np.ndarray, k: int) -> tuple:
    """(10-frame scale error, along-track error m) of the emitted pose ``k`` (truth and estimate as T_o_c0)."""
    first = int(np.argmax(ok))
    sc = np.nan
    if k - DELTA >= first:
        lg = np.linalg.norm(T_gt[k, :3, 3] - T_gt[k - DELTA, :3, 3])
        le = np.linalg.norm(T_est[k, :3, 3] - T_est[k - DELTA, :3, 3])
        sc = le / lg - 1 if lg > 2.0 else np.nan
    p_e = (T_gt[first] @ np.linalg.inv(T_est[first]) @ T_est[k])[:3, 3]
    d = T_gt[min(k + 1, len(T_gt) - 1), :3, 3] - T_gt[max(k - 1, 0), :3, 3]
    along = float((p_e - T_gt[k, :3, 3]) @ d / np.linalg.norm(d)) if np.linalg.norm(d) > 1e-6 else 0.0
    return float(sc), along


def along_sigma(cov, T_est: np.ndarray, k: int) -> float:
    """The estimator's own standard deviation (m) of pose ``k`` along its direction of travel, from
    ``FrameResult.cov`` (``[rotvec, position]`` of ``T_o_c0``); NaN without one or at rest."""
    d = T_est[k, :3, 3] - T_est[max(k - 1, 0), :3, 3]
    if cov is None or k == 0 or np.linalg.norm(d) < 1e-6:
        return float("nan")
    d = d / np.linalg.norm(d)
    return float(np.sqrt(d @ np.asarray(cov)[3:, 3:] @ d))


class FlowBackKlt(KltFrontend):
    """:class:`KltFrontend` whose KLT also tracks each result back (``back_px``), before the F-matrix RANSAC."""

    back_px = 0.5

    def _flow(self, img: np.ndarray) -> tuple:
        p1, ok = super()._flow(img)
        back, st_b, _ = cv2.calcOpticalFlowPyrLK(img, self.prev_img, p1.reshape(-1, 1, 2).astype(np.float32),
                                                 self.px.reshape(-1, 1, 2).copy(), winSize=(21, 21), maxLevel=1,
                                                 flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
        return p1, ok & (st_b.ravel() == 1) & (np.linalg.norm(back.reshape(-1, 2) - self.px, axis=1) <= self.back_px)


def flow_back_frontend(frontend: KltFrontend, back_px: float) -> FlowBackKlt:
    """A fresh :class:`FlowBackKlt` with the settings of ``frontend`` (before its first image)."""
    fb = FlowBackKlt.__new__(FlowBackKlt)
    fb.__dict__.update(frontend.__dict__)
    fb.back_px = float(back_px)
    return fb


class RowMask:
    """Wraps a VINS front-end: no features below image row ``v_min`` (the front-end's ``exclude`` mask)."""

    def __init__(self, frontend, v_min: int):
        self.frontend = frontend
        w, h = frontend.size
        self.mask = np.zeros((h, w), bool)
        self.mask[int(v_min):] = True

    def track(self, img, t_ns, exclude=None):
        return self.frontend.track(img, t_ns, self.mask if exclude is None else (exclude | self.mask))

    def undistort(self, px):
        return self.frontend.undistort(px)


class ExactTracks:
    """Wraps a VINS front-end: same tracks, positions replaced by exact projections + ``noise_px`` noise."""

    def __init__(self, frontend, ds, noise_px: float, rng: np.random.Generator):
        self.frontend, self.ds, self.noise_px, self.rng = frontend, ds, float(noise_px), rng
        self.camera = ds.rig.cameras[0]
        gt = ds.groundtruth_cam0()
        self.T_w_c, self.k_of = gt.T, {int(t): k for k, t in enumerate(gt.t_ns)}
        self.X_w: dict = {}            # track id -> point (None: started at a depth edge)

    def track(self, img, t_ns, exclude=None):
        f = self.frontend.track(img, t_ns, exclude)
        k = self.k_of[int(t_ns)]
        new = np.array([int(i) not in self.X_w for i in f.ids], bool)
        if new.any():
            z, ok = local_depth(np.asarray(self.ds.depth(k, 0), float), f.px[new])
            X = backproject(self.camera, f.px[new], z) @ self.T_w_c[k][:3, :3].T + self.T_w_c[k][:3, 3]
            for i, x, good in zip(f.ids[new], X, ok):
                self.X_w[int(i)] = x if good else None
        keep = np.array([self.X_w[int(i)] is not None for i in f.ids], bool)
        X = np.array([self.X_w[int(i)] for i in f.ids[keep]]).reshape(-1, 3)
        px, front = project(self.camera, self.T_w_c[k], X)
        px = px + self.noise_px * self.rng.standard_normal(px.shape)
        ids, count = f.ids[keep][front], f.count[keep][front]
        px = px[front]
        return replace(f, ids=ids, px=px, xy=self.frontend.undistort(px), count=count)


def run(dataset_path: Path, estimator: str, max_frames: int, options: dict, exact_px=None, seed: int = 0,
        flow_back_px=None, v_min=None) -> dict:
    """Per-keyframe records (dict of arrays) of ``estimator`` on the first ``max_frames`` frames; with
    ``exact_px`` the back-end gets exact track positions plus that much noise (:class:`ExactTracks`), with
    ``flow_back_px`` the front-end checks each track backwards (:class:`FlowBackKlt`), with ``v_min`` it has
    no features below that image row (:class:`RowMask`)."""
    ds = open_dataset(dataset_path)
    truth = TrueStates(dataset_path)
    gt = ds.groundtruth_cam0()
    T_gt = np.linalg.inv(gt.T[0]) @ gt.T

    def frontend(fe):
        """The estimator's front-end with the study's changes (injected through the constructor)."""
        if flow_back_px is not None:
            fe = flow_back_frontend(fe, flow_back_px)
        if v_min is not None:
            fe = RowMask(fe, v_min)
        if exact_px is not None:
            fe = ExactTracks(fe, ds, exact_px, np.random.default_rng(seed))
        return fe

    n = min(max_frames, len(ds))
    T_est, ok, rows = np.tile(np.eye(4), (n, 1, 1)), np.zeros(n, bool), []

    def on_frame(fr, res, est):
        k = fr.index
        T_est[k], ok[k] = res.T_o_c0, res.status != "init"
        if res.status == "keyframe" and est.window is not None:
            rec = keyframe_record(est, truth)
            rec["frame"] = k
            rec["sc10"], rec["along"] = emitted_errors(T_est, ok, T_gt, k)
            rec["sig_along"] = along_sigma(res.cov, T_est, k)
            rows.append(rec)

    est = run_estimator(estimator, ds, {**options, "frontend": frontend}, progress=False, max_frames=n,
                        with_truth=True, on_frame=on_frame).estimator
    if not rows:
        raise TestbedError(f"{dataset_path}: {estimator} did not initialise in {n} frames")
    out = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    out["t_s"] = (out["t_ns"] - int(gt.t_ns[0])) * 1e-9
    out["acc_w"] = est.params.getBiasAccCovariance()[0, 0] ** 0.5
    out["acc_n"] = est.params.getAccelerometerCovariance()[0, 0] ** 0.5
    out["gyr_w"] = est.params.getBiasOmegaCovariance()[0, 0] ** 0.5
    return out


HEADER = (f"{'t s':>5} {'frame':>5} {'speed':>5} {'v_ratio':>7} {'sc10 %':>6} {'along m':>7} "
          f"{'dba_x':>6} {'dba_y':>6} {'dba_z':>6} {'dg_x':>6} {'e_fwd':>6} {'dbg_y':>6} {'|dbg|':>6} {'tilt':>5} "
          f"{'sig_al':>6}")


def format_rows(r: dict, every_s: float) -> str:
    """One row (the last keyframe) per ``every_s`` of data; accelerations in mm/s^2, gyro bias errors
    (``dbg_y``: the pitch axis, IMU y) in mrad/s, tilt (roll and pitch error) in deg."""
    lines = [HEADER]
    bins = np.floor(r["t_s"] / every_s)
    for b in np.unique(bins):
        i = int(np.flatnonzero(bins == b)[-1])
        lines.append(f"{r['t_s'][i]:5.1f} {r['frame'][i]:5d} {r['speed'][i]:5.2f} "
                     f"{r['v_fwd_e'][i] / r['v_fwd_g'][i]:7.3f} {100 * r['sc10'][i]:6.1f} {r['along'][i]:7.2f} "
                     + " ".join(f"{1e3 * x:6.1f}" for x in (*r['dba'][i], r['dg'][i][0], r['e_fwd'][i]))
                     + f" {1e3 * r['dbg'][i][1]:6.3f} {1e3 * np.linalg.norm(r['dbg'][i]):6.3f} "
                     f"{r['tilt_deg'][i]:5.2f} {r['sig_along'][i]:6.2f}")
    return "\n".join(lines)


def cruise_legs(speed: np.ndarray) -> list:
    """[(first, last)] keyframe indices of each run of consecutive keyframes at true speed > 9 m/s."""
    fast = np.flatnonzero(speed > CRUISE_MPS)
    if fast.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(fast) > 1)
    return [(int(fast[i]), int(fast[j])) for i, j in zip(np.r_[0, cuts + 1], np.r_[cuts, fast.size - 1]) if j > i]


def summary(r: dict) -> str:
    """Per cruise leg: measured and predicted (integral of e_fwd) change of the forward velocity error, its
    parts, and the bias walks the IMU model allows over the leg's duration T."""
    legs = cruise_legs(r["speed"])
    if not legs:
        return "summary: no cruise (true speed > 9 m/s) after the initialisation"
    dv = r["v_fwd_e"] - r["v_fwd_g"]
    out = []
    for a, b in legs:
        seg = slice(a, b + 1)
        t, e, sc = r["t_s"][seg], r["e_fwd"][seg], r["sc10"][seg]
        T = t[-1] - t[0]
        pred = float(np.sum(0.5 * (e[1:] + e[:-1]) * np.diff(t)))
        out.append(
            f"cruise {t[0]:.1f}-{t[-1]:.1f} s ({T:.1f} s, {b - a + 1} keyframes): forward velocity error "
            f"{dv[a]:+.3f} -> {dv[b]:+.3f} m/s (change {dv[b] - dv[a]:+.3f}), integral of e_fwd {pred:+.3f} m/s; "
            f"mean e_fwd {1e3 * np.mean(e):+.1f} mm/s^2 = dg_x {1e3 * np.mean(r['dg'][seg, 0]):+.1f} "
            f"- dba_x {1e3 * np.mean(r['dba'][seg, 0]):+.1f}; max |dba_x| {1e3 * np.max(np.abs(r['dba'][seg, 0])):.1f} "
            f"mm/s^2, max |dg_x| {1e3 * np.max(np.abs(r['dg'][seg, 0])):.1f} mm/s^2, max |dbg_y| "
            f"{1e3 * np.max(np.abs(r['dbg'][seg, 1])):.3f} mrad/s; sc10 {100 * np.nanmin(sc):+.1f} .. "
            f"{100 * np.nanmax(sc):+.1f} %, last {100 * sc[-1]:+.1f} %; along-track error {r['along'][a]:+.2f} -> "
            f"{r['along'][b]:+.2f} m (the estimator's own 1-sigma there {r['sig_along'][b]:.2f} m); "
            f"model bias walks over T: acc_w*sqrt(T) {1e3 * r['acc_w'] * np.sqrt(T):.1f} "
            f"mm/s^2, gyr_w*sqrt(T) {1e3 * r['gyr_w'] * np.sqrt(T):.3f} mrad/s")
    return "\n".join(out)


def _value(text: str):
    """YAML value of an ``--opt`` (YAML 1.2 numbers: ``1e-8`` is a float)."""
    return parse_value(text, "--opt", TestbedError)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--estimator", default="vins")
    ap.add_argument("--max-frames", type=int, default=450)
    ap.add_argument("--opt", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--every", type=float, default=5.0, help="seconds of data between printed rows")
    ap.add_argument("--npz", type=Path, help="also save the per-keyframe records here")
    ap.add_argument("--exact-tracks", type=float, metavar="PX", help="exact track positions + PX px noise")
    ap.add_argument("--seed", type=int, default=0, help="seed of the --exact-tracks noise")
    ap.add_argument("--flow-back", type=float, metavar="PX", help="forward-backward KLT check, PX pixels")
    ap.add_argument("--exclude-below", type=int, metavar="V", help="no features below image row V")
    a = ap.parse_args(argv)
    try:
        bad = [o for o in a.opt if "=" not in o]
        if bad:
            raise TestbedError(f"--opt {bad[0]!r}: expected key=value")
        opts = {k: _value(v) for k, v in (o.split("=", 1) for o in a.opt)}
        r = run(a.dataset, a.estimator, a.max_frames, opts, a.exact_tracks, a.seed, a.flow_back,
                a.exclude_below)
    except TestbedError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    oracle = "" if a.exact_tracks is None else f" exact tracks + {a.exact_tracks} px (seed {a.seed})"
    oracle += "" if a.flow_back is None else f" flow-back {a.flow_back} px"
    oracle += "" if a.exclude_below is None else f" no features below row {a.exclude_below}"
    print(f"{a.dataset} {a.estimator} {' '.join(a.opt)}{oracle} (first {a.max_frames} frames)")
    print(format_rows(r, a.every))
    print(summary(r))
    if a.npz:
        np.savez(a.npz, **r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
