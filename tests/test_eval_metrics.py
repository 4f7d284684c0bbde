"""ATE, RPE, drift, GCP table and KITTI metric against hand-computed cases."""
import numpy as np
import pytest

from rigs.records import Gcp
from vo.eval import align, ate, drift, gcp_errors, kitti_errors, route_lengths, rpe
from rigs.geometry import make_T, rot_z, so3_exp
from rigs.trajectory import Trajectory

S = 1_000_000_000


def _from_positions(p, R=None, dt_ns=S):
    p = np.asarray(p, dtype=float)
    R = np.tile(np.eye(3), (len(p), 1, 1)) if R is None else R
    return Trajectory(np.arange(len(p), dtype=np.int64) * dt_ns, np.array([make_T(r, q) for r, q in zip(R, p)]))


def _line(n, step=1.0, scale=1.0):
    return _from_positions(np.c_[np.arange(n) * step * scale, np.zeros(n), np.zeros(n)])


def test_ate_constant_offset_is_offset():
    gt = _line(20)
    est = _from_positions(gt.positions + [0.1, 0.0, 0.0])
    r = ate(gt, align(est, gt, "none")[0])
    assert r.trans.rmse == pytest.approx(0.1, abs=1e-12)     # every error is exactly 0.1 m
    assert r.trans.std == pytest.approx(0.0, abs=1e-12) and r.rot_deg.max == 0.0


def test_ate_of_rigidly_moved_gt_is_zero_after_se3():
    rng = np.random.default_rng(7)
    p = np.cumsum(rng.normal(0, 1, (50, 3)), axis=0)
    R = np.array([so3_exp(rng.normal(0, 0.5, 3)) for _ in range(50)])
    gt = _from_positions(p, R)
    est = gt.transformed(make_T(so3_exp([0.4, -0.3, 1.2]), [10.0, -5.0, 2.0]))
    r = ate(gt, align(est, gt, "se3")[0])
    assert r.trans.rmse < 1e-9 and r.rot_deg.rmse < 1e-6   # rounding only (1e-6 deg ~ 2e-8 rad: acos-free angle)


def test_rpe_per_frame_scale_error():
    gt, est = _line(11), _line(11, scale=1.1)                # each 1 m step estimated as 1.1 m
    r1 = rpe(gt, est, 1, "frames")
    assert r1.pairs.shape == (10, 2) and np.allclose(r1.t_err_m, 0.1, atol=1e-12)
    r2 = rpe(gt, est, 2, "frames")                             # pairs (0,2),(2,4),...,(8,10): errors 0.2 m
    assert r2.pairs[:, 0].tolist() == [0, 2, 4, 6, 8] and r2.trans.mean == pytest.approx(0.2, abs=1e-12)


def test_rpe_per_metre_pairs_from_estimate_or_gt():
    gt, est = _line(11), _line(11, scale=1.1)
    # est path 1.1 m per step: 2.2 >= 2.1 at j = 2 -> pairs (0,2),(2,4).. errors 0.2 m
    r_est = rpe(gt, est, 2.1, "m")
    assert r_est.pairs.tolist() == [[0, 2], [2, 4], [4, 6], [6, 8], [8, 10]]
    assert r_est.trans.rmse == pytest.approx(0.2, abs=1e-12)
    # gt path 1 m per step: 3 >= 2.1 at j = 3 -> pairs (0,3),(3,6),(6,9) errors 0.3 m
    r_gt = rpe(gt, est, 2.1, "m", pairs_from="gt")
    assert r_gt.pairs.tolist() == [[0, 3], [3, 6], [6, 9]] and r_gt.trans.max == pytest.approx(0.3, abs=1e-12)


def test_rpe_rotation_only():
    n = 8                                                      # standing still; estimate yaws 1 deg per frame
    gt = _from_positions(np.zeros((n, 3)))
    est = _from_positions(np.zeros((n, 3)), np.array([rot_z(np.radians(k)) for k in range(n)]))
    r = rpe(gt, est, 1, "frames")
    assert np.allclose(r.r_err_deg, 1.0, atol=1e-9) and r.trans.max == 0.0


def test_drift_straight_line_end_error():
    n = 101                                                    # 100 m straight line, 1 m steps
    gt = _line(n)
    est = _from_positions(gt.positions + np.c_[np.zeros(n), 0.007 * gt.positions[:, 0], np.zeros(n)])
    d = drift(gt, est)
    assert d.end_diff_m == pytest.approx(0.7, abs=1e-12)
    assert d.gt_length_m == pytest.approx(100.0, abs=1e-12)
    assert d.drift_ratio_pct == pytest.approx(0.70, abs=1e-12)
    assert d.est_length_m == pytest.approx(100.0 * np.hypot(1.0, 0.007), abs=1e-9)


def _gcp(name, t_s, p):
    return Gcp(name, int(t_s * S), np.array([p[0], p[1], 0.0]), np.asarray(p, dtype=float))


def test_gcp_table_hand_case():
    gt = _line(11)                                             # x = t (s)
    est = _from_positions(gt.positions + [0.1, -0.2, 0.05])
    gcps = [_gcp("A", 2.5, [2.5, 0.0, 0.0]), _gcp("B", 5.0, [5.0, 0.1, 0.0]), _gcp("C", 7.25, [7.55, 0.0, -0.05])]
    tab = gcp_errors(est, gcps)
    # d = est(t) - truth: A (0.1,-0.2,0.05), B (0.1,-0.3,0.05), C (-0.2,-0.2,0.1)
    assert np.allclose([r.d_xyz for r in tab.rows], [[0.1, -0.2, 0.05], [0.1, -0.3, 0.05], [-0.2, -0.2, 0.1]])
    assert np.allclose(tab.mean_xyz, [0.0, -0.7 / 3, 0.2 / 3], atol=1e-12)
    assert np.allclose(tab.rmsd_xyz, [np.sqrt(0.02), np.sqrt(0.17 / 3), np.sqrt(0.005)], atol=1e-12)


def test_gcp_table_reproduces_seed000_table4():
    diffs = {"C01": (-0.635, 0.668, -0.159), "C02": (-0.927, 0.330, -0.503), "C03": (-0.833, 0.111, -1.082),
             "C04": (-0.257, -0.262, -0.465), "C05": (0.161, -0.260, 0.101), "C06": (0.593, -0.083, 1.065)}
    est = _from_positions(np.zeros((8, 3)))                    # estimate at the origin: d = -truth
    gcps = [_gcp(n, k + 1, -np.array(d)) for k, (n, d) in enumerate(diffs.items())]
    tab = gcp_errors(est, gcps, drift(_line(8), _line(8)))
    # the paper prints 3 decimals: its Mean Diff. and RMSD rows must be reproduced to rounding (5e-4)
    assert np.allclose(tab.mean_xyz, [-0.316, 0.084, -0.174], atol=5e-4)
    assert np.allclose(tab.rmsd_xyz, [0.632, 0.344, 0.684], atol=5e-4)
    text = tab.text()
    for label in ("C06", "Mean Diff. (m)", "RMSD (m)", "± 0.632", "Total length for GCP (m)",
                  "Total length for SVO (m)", "Total diff. (m)", "Drift ratio (%)"):
        assert label in text


def test_kitti_perfect_and_one_percent_scale():
    gt = _line(10001, step=0.1)                                # 1000 m straight line, 0.1 m steps
    perfect = kitti_errors(gt, gt)
    assert not perfect.scaled and perfect.lengths_m == (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0)
    assert perfect.t_err_pct == 0.0 and perfect.r_err_deg_per_m == 0.0 and perfect.n_segments > 0
    r = kitti_errors(gt, _line(10001, step=0.1, scale=1.01))
    # segment error 1% of the chord; the devkit's last frame overshoots len by < 1 step (0.1 m in >= 100 m)
    assert 1.0 - 1e-9 <= r.t_err_pct <= 1.0 * (1 + 0.1 / 100) + 1e-9
    assert set(r.per_length) == set(r.lengths_m)


def test_kitti_lengths_scaled_to_short_route():
    gt = _line(501, step=0.1)                                  # 50 m route
    lengths, scaled = route_lengths(gt.path_length)
    assert scaled and np.allclose(lengths, [5, 10, 15, 20, 25, 30, 35, 40], atol=1e-9)
    r = kitti_errors(gt, _line(501, step=0.1, scale=0.98))
    assert r.scaled and r.t_err_pct == pytest.approx(2.0, rel=0.02)   # overshoot < 0.1 m in >= 5 m: 2%


def test_kitti_rotational_error_of_constant_heading_drift():
    gt = _line(2001, step=0.1)                                 # 200 m straight
    eps = np.radians(0.01)                                     # heading error grows 0.01 deg per metre
    R = np.array([rot_z(eps * s) for s in gt.positions[:, 0]])
    r = kitti_errors(gt, _from_positions(gt.positions, R, dt_ns=S), lengths=[50.0, 100.0])
    # angle(delta) = eps * chord, chord in (len, len + 0.1 m]: r_err = 0.01 deg/m to 0.1 %
    assert r.r_err_deg_per_m == pytest.approx(0.01, rel=2e-3)
