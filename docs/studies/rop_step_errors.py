"""Where ``rop``'s end-point error comes from: per keyframe step against the truth (docs/estimators.md, "rop on
the held-out routes: failed frames, per-step errors, speed").

Usage: PYTHONPATH=.:docs/studies .venv/bin/python docs/studies/rop_step_errors.py DATASET [--top K] [KEY=VALUE ...]
(``DATASET`` one of ours with ground truth, e.g. from ``vo-testbed generate --scenario indoor --seed 11 --out D``;
``KEY=VALUE`` RopConfig options, values parsed as YAML).

Prints
* the end-point error and drift, and its attribution to the frames that chain the trajectory (keyframes and
  failed frames, which become keyframes): with ``E_k`` the estimated and ``G_k`` the true poses (both in the first
  camera's frame), ``H_k = G_k E_k^-1 E_N`` is the end point had the estimate been exact up to chain frame k;
  ``c_k = H_(k-1) - H_k`` sums to the end error. The ``top`` largest with their rotation / translation error of the
  step against the truth, status, pose class and four-view tracks;
* the scale (%) and direction (deg) errors of the chain steps longer than 0.2 m;
* per keyframe step: the ROP step's rotation / translation error and its first-order sigma (``cov_step``), and the
  same errors of the track filter's PnP pose of the same tracks (:class:`vo.rop.moving.TrackFilter`), with means
  and the correlation of the ROP error with its sigma.
"""
import sys

import cv2
import numpy as np
import yaml

from rigs.geometry import so3_log
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
from vo.rop.estimator import RopEstimator


def _deg(R: np.ndarray) -> float:
    return float(np.degrees(np.linalg.norm(so3_log(R))))


class StepRecorder(RopEstimator):
    """``rop`` recording each solved step's ``T_kf_c``, ``cov_step`` and the track filter's PnP pose."""

    def __init__(self, rig, **options):
        super().__init__(rig, **options)
        self.steps = []
        inner = self.uncertainty.on_step

        def on_step(step):
            f = self._filter
            self.steps.append((int(step.t_ns), int(self._t_kf), bool(step.keyframe), step.T_kf_c.copy(),
                               step.cov_step.copy(), None if f.T_kf_c is None else f.T_kf_c.copy()))
            return inner(step)
        self.uncertainty.on_step = on_step


def main(argv):
    top = 10
    if "--top" in argv:
        i = argv.index("--top")
        top = int(argv[i + 1])
        del argv[i:i + 2]
    path, options = argv[0], {k: yaml.safe_load(v) for k, v in (a.split("=", 1) for a in argv[1:])}
    cv2.setNumThreads(1)
    ds = open_dataset(path)
    gt = ds.groundtruth_cam0().T
    G = np.linalg.inv(gt[0]) @ gt
    rows, est_ref = [], []

    def on_frame(frame, r, est):
        est_ref[:] = [est]
        rows.append((r.status, r.pose_class, r.n_features, r.T_o_c0.copy(), est._t_kf == frame.t_ns))
    run_estimator("rop_step_errors:StepRecorder", ds, options, progress=False, on_frame=on_frame)
    E = np.array([r[3] for r in rows])
    N = len(E) - 1
    G = G[:N + 1]
    path_m = float(np.sum(np.linalg.norm(np.diff(G[:, :3, 3], axis=0), axis=1)))
    end = np.linalg.norm(E[N, :3, 3] - G[N, :3, 3])
    print(f"{N + 1} frames, path {path_m:.2f} m, end error {end * 1e3:.1f} mm, drift {100 * end / path_m:.3f} %")
    K = [k for k in range(N + 1) if k in (0, N) or rows[k][4]]
    H = np.array([G[k] @ np.linalg.inv(E[k]) @ E[N] for k in K])
    c = np.linalg.norm(H[:-1, :3, 3] - H[1:, :3, 3], axis=1)
    print(f"{len(K) - 1} chain steps; largest contributions (frame, |c| mm, step rot err deg, step trans err mm, "
          "status, class, four-view tracks):")
    scale, direction = [], []
    for i in np.argsort(-c)[:top]:
        a, b = K[i], K[i + 1]
        dE, dG = np.linalg.inv(E[a]) @ E[b], np.linalg.inv(G[a]) @ G[b]
        print(f"  {b:4d} {c[i] * 1e3:6.1f} {_deg(dE[:3, :3] @ dG[:3, :3].T):6.3f} "
              f"{np.linalg.norm(dE[:3, 3] - dG[:3, 3]) * 1e3:6.1f} {rows[b][0]} {rows[b][1]} {rows[b][2]}")
    for a, b in zip(K, K[1:]):
        dE, dG = np.linalg.inv(E[a]) @ E[b], np.linalg.inv(G[a]) @ G[b]
        u, v = dE[:3, 3], dG[:3, 3]
        if np.linalg.norm(v) > 0.2 and rows[b][1] == "ok":
            scale.append(100 * (np.linalg.norm(u) / np.linalg.norm(v) - 1))
            direction.append(np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1))))
    scale, direction = np.array(scale), np.array(direction)
    print(f"chain steps > 0.2 m: {len(scale)}; scale error mean {scale.mean():.2f} % std {scale.std():.2f} %; "
          f"direction error mean {direction.mean():.3f} deg median {np.median(direction):.3f} deg")
    steps = getattr(est_ref[0], "steps", [])
    times = [int(t) for t in ds.frame_times_ns]
    R = []
    for t, t_kf, is_kf, T, cov, T_pnp in steps:
        if not is_kf or T_pnp is None:
            continue
        Tt = np.linalg.inv(gt[times.index(t_kf)]) @ gt[times.index(t)]
        R.append((_deg(T[:3, :3] @ Tt[:3, :3].T), np.degrees(np.sqrt(np.trace(cov[:3, :3]) / 3)),
                  np.linalg.norm(T[:3, 3] - Tt[:3, 3]) * 1e3, _deg(T_pnp[:3, :3] @ Tt[:3, :3].T),
                  np.linalg.norm(T_pnp[:3, 3] - Tt[:3, 3]) * 1e3))
    if R:
        R = np.array(R)
        print(f"{len(R)} keyframe steps: ROP rotation error mean {R[:, 0].mean():.3f} deg (first-order sigma mean "
              f"{R[:, 1].mean():.3f} deg, correlation with the error {np.corrcoef(R[:, 0], R[:, 1])[0, 1]:.2f}), "
              f"translation error mean {R[:, 2].mean():.1f} mm; the track filter's PnP pose of the same tracks: "
              f"{R[:, 3].mean():.3f} deg, {R[:, 4].mean():.1f} mm")


if __name__ == "__main__":
    main(sys.argv[1:])
