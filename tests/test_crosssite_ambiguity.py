"""The cross-site localizer's second-motion check (``localizer.second_motion``): a tie set holding two
self-consistent rigid motions is ``ambiguous``; ties that merely missed the first resection consensus by
a few pixels are the same motion. Exact synthetic ties (points in the previous site's stereo from the
true depth, current pixels by projection)."""
import dataclasses

import numpy as np

from rigs.geometry import make_T, rot_z
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.localizer import resection_inliers, initial_pose, second_motion
from vo.crosssite.regions import project
from vo.crosssite.ties import TieSet
from vo.crosssite.types import Site, StereoCal, StereoPair

K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
B = 0.27
T_B_C = make_T(np.array([[0, 0, 1.0], [-1, 0, 0], [0, -1, 0]]), [0, 0, 1.5])
T0 = np.eye(4)
T1 = make_T(rot_z(0.1), [8.0, 0.5, 0.0])
T1_WRONG = make_T(rot_z(0.13), [5.0, 1.5, 0.0])          # 3.2 m and 1.7 deg from the truth


def _sites(T_prior):
    cal = StereoCal(K, make_T(np.eye(3), [B, 0, 0]), 640, 480)
    img = np.zeros((480, 640), np.uint8)
    prev = Site(0, 0, (StereoPair(img, img, T_B_C),), cal, T0, np.eye(6) * 1e-4)
    cur = Site(1, 1, (StereoPair(img, img, T_B_C),), cal, T_prior, np.diag([0.03 ** 2] * 3 + [1.2 ** 2] * 3))
    return prev, cur


def _ties(groups):
    """``groups``: [(P_w (n,3), current body pose that produced the current pixels)]."""
    uv0, uv1, ur0 = [], [], []
    for P_w, T_cur in groups:
        u0, z0 = project(T0 @ T_B_C, K, P_w)
        u1, _ = project(T_cur @ T_B_C, K, P_w)
        uv0.append(u0), uv1.append(u1), ur0.append(u0[:, 0] - K[0, 0] * B / z0)
    uv0, uv1, ur0 = np.vstack(uv0), np.vstack(uv1), np.concatenate(ur0)
    n = len(uv0)
    t = TieSet(np.zeros(n, int), uv0, np.zeros(n, int), uv1)
    t.ur_prev, t.ur_cur, t.stereo_ok, t.inlier = ur0, np.full(n, np.nan), np.ones(n, bool), np.ones(n, bool)
    return t


def _points(rng, n):
    return np.column_stack([rng.uniform(12, 30, n), rng.uniform(-5, 5, n), rng.uniform(-0.3, 0.3, n)])


def _check(ties, T_prior):
    prev, cur = _sites(T_prior)
    cfg = CrossSiteConfig()
    idx = np.arange(len(ties.pair_prev))
    T_init, P_w = initial_pose(cur, T0, prev, ties, idx, cfg)
    keep = resection_inliers(cur, T_init, P_w, ties, idx, cfg)
    return T_init, keep, second_motion(cur, ties, idx, P_w, keep, T_init, cfg)


def test_two_rigid_motions_are_ambiguous():
    rng = np.random.default_rng(7)
    ties = _ties([(_points(rng, 40), T1), (_points(rng, 70), T1_WRONG)])
    T_init, keep, reason = _check(ties, make_T(rot_z(0.12), [6.5, 1.0, 0.0]))
    assert np.linalg.norm(T_init[:3, 3] - T1_WRONG[:3, 3]) < 1e-3     # the larger, wrong cluster wins the resection
    assert keep.sum() == 70 and reason is not None and "two motions" in reason


def test_one_motion_with_near_misses_is_not_ambiguous():
    """Half the ties moved by 3-5 px (beyond the 2 px consensus, as far points' range errors do): they
    form a second consensus, but it reprojects within a few pixels under the first pose."""
    rng = np.random.default_rng(8)
    ties = _ties([(_points(rng, 80), T1)])
    off = rng.uniform(3.0, 5.0, 40) * np.array([1.0, -1.0])[rng.integers(0, 2, 40)]
    ties.uv_cur[:40, 0] += off
    _, keep, reason = _check(ties, make_T(rot_z(0.1), [7.0, 0.0, 0.0]))
    assert keep.sum() >= 40 and reason is None


def test_check_is_off_at_zero():
    rng = np.random.default_rng(7)
    ties = _ties([(_points(rng, 40), T1), (_points(rng, 70), T1_WRONG)])
    prev, cur = _sites(T1)
    cfg = dataclasses.replace(CrossSiteConfig(), ambiguity_px=0.0)
    idx = np.arange(len(ties.pair_prev))
    T_init, P_w = initial_pose(cur, T0, prev, ties, idx, cfg)
    keep = resection_inliers(cur, T_init, P_w, ties, idx, cfg)
    assert second_motion(cur, ties, idx, P_w, keep, T_init, cfg) is None
