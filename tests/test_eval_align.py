"""Umeyama and trajectory alignment against known, noise-free transforms."""
import numpy as np
import pytest

from vo.errors import VoError
from vo.eval import align, umeyama
from rigs.geometry import make_T, so3_exp
from rigs.trajectory import Trajectory


def _points(seed=1, n=20):
    return np.random.default_rng(seed).normal(0.0, 3.0, (n, 3))


def test_umeyama_recovers_known_sim3_exactly():
    src = _points()
    R_true, t_true, s_true = so3_exp([0.3, -1.1, 0.7]), np.array([4.0, -2.0, 0.5]), 1.7
    dst = s_true * src @ R_true.T + t_true
    R, t, s = umeyama(src, dst, with_scale=True)
    # noise-free closed form: only rounding error (~1e-15 relative on 10 m scale numbers)
    assert np.allclose(R, R_true, atol=1e-9) and np.allclose(t, t_true, atol=1e-9)
    assert s == pytest.approx(s_true, abs=1e-9)


def test_umeyama_se3_gives_unit_scale_and_exact_pose():
    src = _points(2)
    R_true, t_true = so3_exp([-0.4, 0.2, 2.5]), np.array([0.1, 10.0, -3.0])
    R, t, s = umeyama(src, src @ R_true.T + t_true, with_scale=False)
    assert s == 1.0
    assert np.allclose(R, R_true, atol=1e-9) and np.allclose(t, t_true, atol=1e-9)


def test_umeyama_reflection_fix_returns_proper_rotation():
    src = _points(3)
    dst = src * np.array([1.0, 1.0, -1.0])            # a mirror image: best orthogonal map is a reflection
    R, _, _ = umeyama(src, dst, with_scale=False)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)


def _traj(n=30):
    t = np.arange(n, dtype=np.int64) * 50_000_000
    T = np.array([make_T(so3_exp([0.01 * k, 0.02, 0.05 * k]), [k * 0.3, np.sin(0.2 * k), 0.05 * k]) for k in range(n)])
    return Trajectory(t, T)


def test_align_sim3_and_first_recover_gt():
    gt = _traj()
    T_x = make_T(so3_exp([0.2, 0.1, -1.0]), [5.0, 1.0, -2.0])
    est_se3 = gt.transformed(T_x)
    for method in ("se3", "first"):
        out, info = align(est_se3, gt, method)
        assert np.allclose(out.T, gt.T, atol=1e-9), method
        assert info.s == 1.0
    est_sim3 = Trajectory(gt.t_ns, gt.T.copy())
    est_sim3.T[:, :3, 3] *= 0.5                       # scale-ambiguous monocular-like estimate
    out, info = align(est_sim3, gt, "sim3")
    assert info.s == pytest.approx(2.0, abs=1e-9)
    assert np.allclose(out.positions, gt.positions, atol=1e-9)


def test_align_posyaw_recovers_yaw_and_translation():
    gt = _traj()
    T_x = make_T(so3_exp([0.0, 0.0, 0.8]), [2.0, -1.0, 0.3])    # pure yaw + translation: 4-DoF exact
    out, info = align(gt.transformed(T_x), gt, "posyaw")
    assert np.allclose(out.T, gt.T, atol=1e-9)
    assert np.allclose(info.R, T_x[:3, :3].T, atol=1e-9)


def test_align_unknown_method_lists_valid_ones():
    gt = _traj(5)
    with pytest.raises(VoError, match="valid: se3, sim3, none, first, posyaw"):
        align(gt, gt, "affine")
