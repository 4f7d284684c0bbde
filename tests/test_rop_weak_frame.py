"""A failed frame's pose from a small PnP fit, accepted only when well conditioned (vo.rop.weak_frame)."""
from types import SimpleNamespace

import numpy as np
import pytest

from rigs.geometry import inv_T, make_T, so3_exp, so3_log
from rigs.presets import get_rig
from vo.errors import EstimatorError
from vo.rop.rop_config import RopConfig
from vo.rop.weak_frame import MAX_ROTATION_SIGMA_DEG, MIN_POINTS, rotation_miss, weak_frame_pose

RIG = get_rig("cart27")                    # 720x480, 0.2857 m baseline, with lens distortion
T_KF_C = make_T(so3_exp(np.radians([0.5, 4.5, 0.3])), [0.05, -0.01, 0.07])   # a fast turn: 4.5 deg, 7 cm


def _view(p_kf: np.ndarray, noise_px: float = 0.0, seed: int = 0):
    """Tracks of the world points ``p_kf`` (keyframe left-camera frame) in the keyframe pair and the current left
    image, through the rig's lens model, with iid pixel noise."""
    rng = np.random.default_rng(seed)
    c0, c1 = RIG.cameras[:2]
    p1 = c0.project(p_kf)
    p2 = c1.project(p_kf @ inv_T(RIG.T_c0_c1)[:3, :3].T + inv_T(RIG.T_c0_c1)[:3, 3])
    T_c_kf = inv_T(T_KF_C)
    p3 = c0.project(p_kf @ T_c_kf[:3, :3].T + T_c_kf[:3, 3])
    p1, p2, p3 = (p + noise_px * rng.standard_normal(p.shape) for p in (p1, p2, p3))
    return SimpleNamespace(p1=p1, p2=p2, p3=p3)


def _wall_points(n: int, half_width: float, depth: float, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-half_width, half_width, (n, 2))
    return np.c_[xy, depth + rng.uniform(-0.3, 0.3, n)]


def _rot_err_deg(T_a, T_b) -> float:
    return float(np.degrees(np.linalg.norm(so3_log(T_a[:3, :3] @ T_b[:3, :3].T))))


def test_fifteen_spread_tracks_give_the_true_pose_and_pass_the_gate():
    # 15 tracks on a wall 3 m ahead, spread over the image: the indoor failure's case
    w = weak_frame_pose(_view(_wall_points(15, 1.5, 3.0), noise_px=0.2), RIG, np.eye(4), 2.0, 0.5)
    assert w is not None and w.ok, w
    assert w.n_inliers == 15
    # first-order rotation sigma of 15 points 3 m away at the 0.3 px floor: 0.09 deg (rotation about y and x-translation
    # nearly confounded over a 0.6 m depth range); the fit (0.21 deg off here) lies within 4 sigma
    assert w.rotation_sigma_deg < MAX_ROTATION_SIGMA_DEG
    assert _rot_err_deg(w.T_kf_c, T_KF_C) < 4 * w.rotation_sigma_deg
    assert np.linalg.norm(w.T_kf_c[:3, 3] - T_KF_C[:3, 3]) < 0.02


def test_a_far_bunched_patch_is_ill_conditioned_and_rejected():
    # 12 tracks in a 0.6 m patch 25 m away: rotation and translation are not separable
    w = weak_frame_pose(_view(_wall_points(12, 0.3, 25.0), noise_px=0.3), RIG, np.eye(4), 2.0, 10.0)
    assert w is not None
    assert not w.ok and "ill-conditioned" in w.why
    assert w.rotation_sigma_deg > MAX_ROTATION_SIGMA_DEG


def test_a_fit_far_from_the_prediction_is_rejected_and_too_few_tracks_give_none():
    view = _view(_wall_points(15, 1.5, 3.0), noise_px=0.2)
    far_prior = make_T(np.eye(3), [2.0, 0.0, 0.0])                 # 2 m off the fit's camera position
    w = weak_frame_pose(view, RIG, far_prior, 2.0, 0.5)
    assert w is not None and not w.ok and "from the prediction" in w.why
    few = SimpleNamespace(p1=view.p1[:MIN_POINTS - 1], p2=view.p2[:MIN_POINTS - 1], p3=view.p3[:MIN_POINTS - 1])
    assert weak_frame_pose(few, RIG, np.eye(4), 2.0, 0.5) is None


def test_the_rotation_gate_lets_a_small_disagreement_through_and_stops_a_larger_one():
    T_pnp = make_T(so3_exp(np.radians([0.0, 4.5, 0.0])), [0.05, 0.0, 0.3])
    near = make_T(so3_exp(np.radians([0.0, 4.65, 0.0])), [0.06, 0.0, 0.33])   # 0.15 deg and 3 cm apart
    far = make_T(so3_exp(np.radians([0.0, 4.5, 0.3])), T_pnp[:3, 3])          # 0.3 deg apart, same position
    assert rotation_miss(near, T_pnp, 0.2) == ""
    assert "0.30 deg > 0.2 deg" in rotation_miss(far, T_pnp, 0.2)
    assert rotation_miss(far, None, 0.2) == ""                                 # no PnP pose: nothing to compare


def test_the_rotation_gate_is_a_validated_option():
    assert RopConfig().pnp_rotation_gate_deg == 0.2
    assert RopConfig.from_options({"pnp_rotation_gate_deg": 0.5}).pnp_rotation_gate_deg == 0.5
    with pytest.raises(EstimatorError, match="rop.pnp_rotation_gate_deg"):
        RopConfig.from_options({"pnp_rotation_gate_deg": 0})
