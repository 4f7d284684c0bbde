"""The ROP and PnP rotations of each step against the truth, and the rotation test's statistic
(docs/estimators.md, "The rotation test"; :mod:`vo.rop.rotation_test`).

Usage: PYTHONPATH=.:docs/studies .venv/bin/python docs/studies/rop_rotation_test_study.py DATASET [KEY=VALUE ...]
(``DATASET`` with ground truth: ours, or the real KITTI excerpt; ``KEY=VALUE`` RopConfig options, YAML values).

For every ROP step that has the track filter's PnP pose: the angle between the two rotations, the test's
``d2`` (both covariances), and for each fit its rotation error against the truth and that error's
Mahalanobis distance in its own covariance (``e^T C^-1 e``: chi-square with 3 dof, mean 3, where the
covariance is right). Prints the medians and means, the fraction of steps over ``chi2_3(0.99)``, and with
``--rows`` one line per step. The run itself is the configured one (the test acts as configured).
"""
import sys

import cv2
import numpy as np
import yaml

from rigs.geometry import so3_log
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
from vo.rop.estimator import RopEstimator
from vo.rop.rotation_test import chi2_threshold, rotation_test, track_pnp_rotation_cov


class TestRecorder(RopEstimator):
    """``rop`` recording, per ROP step with a PnP pose: ``(t_kf, t, R_rop, C_rop_left, R_pnp, C_pnp_right)``."""

    def __init__(self, rig, **options):
        super().__init__(rig, **options)
        self.records = []

    def _rotation_miss(self, T_kf_c, cov_step):
        T_pnp = self._pnp_pose()
        if T_pnp is not None and self.klt is not None:
            f = self.track_filter_config
            C = track_pnp_rotation_cov(self.klt.view, self.rig, T_pnp, self.config.moving_reproj_px, f.max_depth,
                                       f.max_triangulation_px)
            if C is not None:
                self.records.append((int(self._t_kf), int(self._t_now), T_kf_c[:3, :3].copy(),
                                     np.asarray(cov_step)[:3, :3].copy(), T_pnp[:3, :3].copy(), C,
                                     None if self._apost is None else self._apost[:3, :3].copy()))
        return super()._rotation_miss(T_kf_c, cov_step)

    def _adjust(self, ropset, timings):
        out = super()._adjust(ropset, timings)
        self._apost = None if out[2] is None or out[2][4] is None else out[2][4].cov_apost
        return out

    def process(self, frame):
        self._t_now = int(frame.t_ns)
        return super().process(frame)


def _maha(e, C) -> float:
    return float(e @ np.linalg.solve(C, e))


def main(argv):
    rows = "--rows" in argv
    argv = [a for a in argv if a != "--rows"]
    path, options = argv[0], {k: yaml.safe_load(v) for k, v in (a.split("=", 1) for a in argv[1:])}
    cv2.setNumThreads(1)
    ds = open_dataset(path)
    gt = ds.groundtruth_cam0().T
    times = [int(t) for t in ds.frame_times_ns]
    est_ref = []
    run_estimator("rop_rotation_test_study:TestRecorder", ds, options, progress=False,
                  on_frame=lambda frame, r, est: est_ref.__setitem__(slice(None), [est]))
    out = []
    for t_kf, t, R, C_rop, R_pnp, C_pnp, C_apost in est_ref[0].records:
        Rt = (np.linalg.inv(gt[times.index(t_kf)]) @ gt[times.index(t)])[:3, :3]
        test = rotation_test(R, C_rop, R_pnp, C_pnp, 0.99)
        e_rop, e_pnp = so3_log(Rt.T @ R), so3_log(Rt.T @ R_pnp)          # right perturbations
        C_rop_r = R.T @ C_rop @ R
        out.append((test.angle_deg, test.d2, np.degrees(np.sqrt(np.trace(C_rop_r) / 3)),
                    np.degrees(np.sqrt(np.trace(C_pnp) / 3)), np.degrees(np.linalg.norm(e_rop)),
                    np.degrees(np.linalg.norm(e_pnp)), _maha(e_rop, C_rop_r), _maha(e_pnp, C_pnp),
                    np.degrees(np.sqrt(np.trace(C_apost) / 3)), _maha(e_rop, R.T @ C_apost @ R)))
        if rows:
            print(f"{t / 1e9:8.2f} " + " ".join(f"{v:8.3f}" for v in out[-1]))
    A = np.array(out)
    names = ("angle deg", "d2", "sigma_rop deg", "sigma_pnp deg", "rop err deg", "pnp err deg",
             "rop err d2 (own cov)", "pnp err d2 (own cov)",
             "sigma_rop a-post deg", "rop err d2 (a-post)")
    print(f"{len(A)} ROP steps with a PnP pose; chi2_3(0.99) = {chi2_threshold(0.99):.2f}; "
          f"d2 above it on {np.mean(A[:, 1] > chi2_threshold(0.99)):.1%}")
    for i, n in enumerate(names):
        print(f"  {n:22s} median {np.median(A[:, i]):9.4f} mean {A[:, i].mean():9.4f}")


if __name__ == "__main__":
    main(sys.argv[1:])
