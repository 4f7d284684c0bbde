"""Timestamp association and pose interpolation."""
import numpy as np
import pytest

from vo.errors import VoError
from vo.eval import associate, interpolate
from rigs.geometry import make_T, rot_z
from vo.eval.rotation import angle_rad
from rigs.trajectory import Trajectory


def _line(t_ns):
    t_ns = np.asarray(t_ns, dtype=np.int64)
    T = np.array([make_T(rot_z(1e-9 * t), [1e-9 * t, 0.0, 0.0]) for t in t_ns])   # x = t (s), yaw = t (rad)
    return Trajectory(t_ns, T)


def test_associate_nearest_within_tolerance_one_to_one():
    gt = _line(np.arange(10) * 100_000_000)                          # 10 Hz
    est_t = np.array([0, 3_000_000, 99_000_000, 250_000_000, 420_000_000, 900_000_000 + 20_000_000])
    g, e = associate(gt, _line(est_t), max_diff_ns=10_000_000)
    # 0 and 3 ms both match gt 0 -> keep the exact one; 99 ms -> gt 100 ms; 250/420 ms: > 10 ms away; 920 ms: 20 ms away
    assert g.t_ns.tolist() == [0, 100_000_000]
    assert e.t_ns.tolist() == [0, 99_000_000]


def test_associate_exact_equal_stamps_and_no_match_error():
    gt = _line(np.arange(5) * 10)
    g, e = associate(gt, gt)
    assert len(g) == len(e) == 5 and np.array_equal(g.t_ns, e.t_ns)
    with pytest.raises(VoError, match="no timestamps match"):
        associate(gt, _line([10**12]))


def test_interpolate_linear_position_and_slerp_rotation():
    traj = Trajectory(np.array([0, 1_000_000_000], dtype=np.int64),
                      np.array([make_T(np.eye(3), [0, 0, 0]), make_T(rot_z(0.8), [2.0, -4.0, 1.0])]))
    out = interpolate(traj, [250_000_000, 500_000_000])
    assert np.allclose(out.positions, [[0.5, -1.0, 0.25], [1.0, -2.0, 0.5]], atol=1e-12)
    # SLERP about a fixed axis: angle grows linearly, 0.2 and 0.4 rad (1e-12: rounding only)
    assert np.allclose(angle_rad(out.rotations), [0.2, 0.4], atol=1e-12)
    assert np.allclose(out.rotations[1], rot_z(0.4), atol=1e-12)


def test_interpolate_outside_range_raises():
    traj = _line([0, 10, 20])
    with pytest.raises(VoError, match="outside trajectory range"):
        interpolate(traj, [25])
