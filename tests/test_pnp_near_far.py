"""The close/far split of the stereo PnP (``vo.estimators.near_far``) against exact geometry.

Scene: a KITTI-like rig (f 718 px, baseline 0.54 m: 40 baselines = 21.5 m, 18 px disparity), landmarks
triangulated in frame 0 (= ``o``) and seen exactly in frame 1 after 1 m forward, 0.2 m right and 2.5 deg of
yaw (the real turn's step). With ``delta`` the stereo pairs carried a disparity offset: every landmark is
``d / (d - delta)`` too far along its ray (as on the real KITTI excerpt, 1.4 px), so a step fitted on
landmarks at disparity ``d`` is long by that factor.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rigs.geometry import inv_T, make_T, rot_y, rotation_angle, transform_points
from rigs.geometry.pinhole import project
from vo.estimators.near_far import NearFarGate, refine_on_near
from vo.estimators.pnp_core import PnpConfig, solve_pnp

F, B = 718.0, 0.54
K = np.array([[F, 0, 620.0], [0, F, 187.0], [0, 0, 1]])
SPLIT = PnpConfig(near_baselines=40.0)      # the split on (ORB-SLAM2's 40 baselines; off by default)
W, H = 1241, 376
T_O_C1 = make_T(rot_y(np.radians(2.5)), np.array([0.2, 0.0, 1.0]))


def _scene(rng, n_near: int, n_far: int, delta: float):
    """-> (p_o as triangulated, x exact pixels in frame 1, near (N,) bool, disparity (N,))."""
    pts = []
    for n, (z0, z1) in ((n_near, (6.0, 20.0)), (n_far, (25.0, 70.0))):
        got = []
        while len(got) < n:
            p = np.c_[rng.uniform(-30, 30, 500), rng.uniform(-3, 1.6, 500), rng.uniform(z0, z1, 500)]
            uv0, uv1 = project(p, K), project(transform_points(inv_T(T_O_C1), p), K)
            ok = np.all((uv0 >= 0) & (uv0 < [W, H]) & (uv1 >= 0) & (uv1 < [W, H]), axis=1)
            got.extend(p[ok])
        pts.append(np.array(got[:n]))
    p_true = np.vstack(pts)
    d = F * B / p_true[:, 2]
    p_o = p_true * (d / (d - delta))[:, None]            # too far along the ray from camera 0
    x = project(transform_points(inv_T(T_O_C1), p_true), K)
    return p_o, x, p_true[:, 2] < 40 * B, d


def _step_ratio(T_o_c1):
    return np.linalg.norm(T_o_c1[:3, 3]) / np.linalg.norm(T_O_C1[:3, 3])


def _solve(p_o, x, near, config=SPLIT):
    """The joint PnP fit, then the split -> ``(T_o_c1, inliers)``."""
    T_o_c1, inl = solve_pnp(p_o, x, K, config, T_o_c0_prior=np.eye(4))
    T_c1_o, inl = refine_on_near(inv_T(T_o_c1), inl, near, (np.zeros_like(p_o), p_o), p_o, x, K, config)
    return inv_T(T_c1_o), inl


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_far_landmarks_set_direction_not_length_under_a_disparity_offset(seed):
    p_o, x, near, d = _scene(np.random.default_rng(seed), n_near=30, n_far=150, delta=1.4)
    joint, _ = _solve(p_o, x, near, PnpConfig(near_baselines=0))
    split, inl = _solve(p_o, x, near)
    # prediction: a step fitted on landmarks at disparity d is long by d / (d - 1.4); the joint fit mixes the
    # far ones (8-28 % long) into it, the split takes its length from the near ones only (at most
    # 1.4 / (18 - 1.4) = 8 %; over seeds 0-5 the joint fit is 6-12 % long, the split 4-5 %)
    bias_near = d[near] / (d[near] - 1.4)
    assert _step_ratio(joint) > bias_near.mean()
    assert 1.0 < _step_ratio(split) <= bias_near.max()
    assert _step_ratio(split) < _step_ratio(joint) - 0.01
    assert rotation_angle(inv_T(T_O_C1) @ split) < np.radians(0.1)
    assert inl[~near].all()                                  # far rays: every far landmark stays a track
    assert inl[near].sum() >= 0.9 * near.sum()               # near landmarks re-gated under the refitted pose


def test_exact_landmarks_give_the_true_pose_with_or_without_the_split():
    p_o, x, near, _ = _scene(np.random.default_rng(3), n_near=30, n_far=150, delta=0.0)
    for cfg in (SPLIT, PnpConfig(near_baselines=0)):
        T, inl = _solve(p_o, x, near, cfg)
        assert np.linalg.norm(T[:3, 3] - T_O_C1[:3, 3]) < 1e-6 and inl.all()


def test_too_few_near_landmarks_keep_the_joint_fit():
    p_o, x, near, _ = _scene(np.random.default_rng(4), n_near=8, n_far=150, delta=1.4)
    cfg = SPLIT
    assert near.sum() < cfg.min_near_inliers
    T_o_c1, inl = solve_pnp(p_o, x, K, cfg, T_o_c0_prior=np.eye(4))
    T_c1_o = inv_T(T_o_c1)
    for config, flags in ((cfg, near), (dataclasses.replace(cfg, near_baselines=0), np.ones_like(near))):
        T, inl_out = refine_on_near(T_c1_o, inl, flags, (np.zeros_like(p_o), p_o), p_o, x, K, config)
        assert T is T_c1_o and inl_out is inl                 # the joint fit, unchanged


def test_gate_needs_a_consistent_disagreement_beyond_the_calibration_tolerance():
    """Limit: 0.5 px at the boundary disparity 718 / 40 = 17.95 px -> far steps more than 2.79 % off."""
    cfg = SPLIT
    gate = NearFarGate(cfg, F, B)
    assert gate.limit == pytest.approx(0.5 * 40 / 718)
    # an exact calibration: the far landmarks' step scatters around the near ones' (+-2 %): never
    assert not any(gate.use_split(1.0 + e, 1.0) for e in (0.02, -0.02, 0.01, -0.015, 0.02, -0.01, 0.0))
    # standing still: steps of a millimetre disagree by 100 %, but say nothing before a baseline of travel
    gate = NearFarGate(cfg, F, B)
    assert not any(gate.use_split(0.002, 0.001) for _ in range(20))
    # the real excerpt: far landmarks 6 % longer on every frame; not before min_frames frames
    gate = NearFarGate(cfg, F, B)
    used = [gate.use_split(1.06, 1.0) for _ in range(8)]
    assert used == [False] * (NearFarGate.min_frames - 1) + [True] * (9 - NearFarGate.min_frames)
    gate = NearFarGate(cfg, F, B)                                  # either sign
    assert [gate.use_split(1.0, 1.06) for _ in range(5)][-1]
    assert not NearFarGate(dataclasses.replace(cfg, near_baselines=0), F, B).use_split(2.0, 1.0)
