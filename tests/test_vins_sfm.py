"""The start's SfM (vo/vins/sfm.py): when the newest keyframe pairs with no older one (fewer than MIN_COMMON
features in common, as in traffic), an earlier pair of the window is the reference and the newest is chained
by PnP; the recovered camera centres equal the truth up to one scale. And the window check's scale change."""
import numpy as np

from vo.vins.feature_tracker import FeatureFrame
from vo.vins.sfm import MIN_COMMON, reference_pair, sfm
from vo.vins.vi_init import InitResult, window_scale_change

F = 460.0


def _keyframe(k: int, pts: np.ndarray, ids: np.ndarray, rng) -> tuple:
    """Keyframe ``k`` at centre ``(0.4 k, 0, 1.0 k)`` m (identity rotation) seeing world points ``pts`` (N,3)
    with track ``ids`` (N,), 0.05 px image noise at F -> (FeatureFrame, centre (3,))."""
    c = np.array([0.4 * k, 0.0, 1.0 * k])
    p_c = pts - c
    xy = p_c[:, :2] / p_c[:, 2:] + rng.normal(0, 0.05 / F, (len(pts), 2))
    return FeatureFrame(k * 10 ** 8, ids.astype(np.int64), xy * F, xy, np.ones(len(ids), np.int64)), c


def _frames(n_old: int = 6, n_newest_common: int = 15, seed: int = 0):
    """Keyframes of a camera moving forward and sideways past 200 points 15-40 m ahead (identity rotation,
    centres ``(0.4 k, 0, 1.0 k)`` m); the newest sees only ``n_newest_common`` of those points plus 100 of
    its own. Image noise 0.05 px at F. -> (frames, true centres (n,3))."""
    rng = np.random.default_rng(seed)
    P = rng.uniform([-10, -3, 15], [10, 3, 40], (200, 3))
    P_new = rng.uniform([-10, -3, 25], [10, 3, 45], (100, 3))
    frames, centres = [], []
    for k in range(n_old + 1):
        if k < n_old:
            pts, ids = P, np.arange(200)
        else:
            pts, ids = np.vstack([P[:n_newest_common], P_new]), np.r_[np.arange(n_newest_common), 1000 + np.arange(100)]
        frame, c = _keyframe(k, pts, ids, rng)
        frames.append(frame)
        centres.append(c)
    return frames, np.array(centres)


def test_reference_pair_steps_back_when_the_newest_pairs_with_no_keyframe():
    frames, centres = _frames()
    assert len(np.intersect1d(frames[-1].ids, frames[0].ids)) < MIN_COMMON
    a, b, _ = reference_pair(frames, 30.0, F)
    assert b == len(frames) - 2 and a < b          # the newest is skipped, the next-newest pairs


def test_sfm_from_an_earlier_pair_recovers_every_keyframe_up_to_scale():
    """Centres relative to the reference keyframe, scaled by least squares onto the truth: within 1 cm on a
    6 m path (noise 0.05 px); rotations within 0.05 deg of the identity."""
    frames, centres = _frames()
    ref, (T_c_v, points) = sfm(frames, 30.0, F)
    T_v_c = np.linalg.inv(T_c_v)
    p, q = T_v_c[:, :3, 3], centres - centres[ref]
    s = np.sum(p * q) / np.sum(p * p)
    assert np.max(np.linalg.norm(s * p - q, axis=1)) < 0.01, s * p - q
    for R in T_v_c[:, :3, :3]:
        assert np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))) < 0.05
    assert len(points) > 100


def test_sfm_fails_when_no_pair_qualifies():
    frames, _ = _frames(n_old=2)                   # too little parallax between any two keyframes
    assert reference_pair(frames, 30.0, F) is None and sfm(frames, 30.0, F) is None


def test_window_scale_change_is_the_relative_change_of_the_distances():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [2, 1, 0], [4, 1, 0]])
    r = InitResult(0, np.tile(np.eye(3), (4, 1, 1)), p, {}, np.zeros(3), 2.0, np.zeros(3), np.zeros((4, 3)))
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, 3] = 5.0 + 1.1 * 2.0 * p               # shifted and 10 % larger than the aligned SfM
    assert abs(window_scale_change(r, T) - 0.1) < 1e-12
    T[:, :3, 3] = 2.0 * p
    assert abs(window_scale_change(r, T)) < 1e-12


def _rest_frames(seed: int = 1):
    """Seven keyframes as :func:`_frames` (centres ``(0.4 k, 0, 1.0 k)`` m), where the oldest shares its tracks
    only with the next two (60 points; a start from rest whose early tracks die before the reference), the
    next two share 30 more with keyframes 3 and 4, and keyframes 3-6 share 200 (12-30 m ahead, so that the
    pair (3, 6) has 30 px of parallax). The reference pair is (3, 6), so keyframe 0 can be posed only from
    points triangulated between keyframes 1 and 2."""
    rng = np.random.default_rng(seed)
    A = rng.uniform([-10, -3, 15], [10, 3, 40], (60, 3))
    B1 = rng.uniform([-10, -3, 20], [10, 3, 40], (30, 3))
    B = rng.uniform([-10, -3, 12], [10, 3, 30], (200, 3))
    sets = {0: [(A, 0)], 1: [(A, 0), (B1, 100)], 2: [(A, 0), (B1, 100)], 3: [(B1, 100), (B, 1000)],
            4: [(B1, 100), (B, 1000)], 5: [(B, 1000)], 6: [(B, 1000)]}
    frames, centres = [], []
    for k in range(7):
        pts = np.vstack([P for P, _ in sets[k]])
        ids = np.concatenate([off + np.arange(len(P)) for P, off in sets[k]])
        frame, c = _keyframe(k, pts, ids, rng)
        frames.append(frame)
        centres.append(c)
    return frames, np.array(centres)


def test_a_keyframe_before_the_reference_is_posed_from_tracks_its_later_neighbours_share():
    """Each keyframe posed by PnP before the reference triangulates its tracks with every posed keyframe, so
    the oldest (tracks shared with keyframes 1 and 2 only, none with the reference) is posed: its centre within
    1 cm of the truth on the 7 m path, up to the one scale. Triangulating only with the reference (VINS-Mono's
    ``GlobalSFM``) leaves it no point, and the SfM fails."""
    frames, centres = _rest_frames()
    a, b, _ = reference_pair(frames, 30.0, F)
    assert (a, b) == (3, 6)
    ref, (T_c_v, _) = sfm(frames, 30.0, F)
    T_v_c = np.linalg.inv(T_c_v)
    p, q = T_v_c[:, :3, 3], centres - centres[ref]
    s = np.sum(p * q) / np.sum(p * p)
    assert np.max(np.linalg.norm(s * p - q, axis=1)) < 0.01, s * p - q
