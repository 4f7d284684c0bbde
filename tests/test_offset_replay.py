"""Re-chaining the frames tracked before the disparity offset was known (``vo.estimators.offset_replay``),
against exact geometry."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from rigs.geometry import inv_T, make_T, rot_y, transform_points
from vo.dataset import open_dataset
from vo.estimators.disparity_offset import DisparityOffset, OffsetConfig
from vo.estimators.offset_replay import ChainRecord
from vo.estimators.pnp import KltPnpEstimator
from vo.frontend.klt import stereo_klt
from vo.frontend.stereo import triangulate

F, B = 700.0, 0.5
K = np.array([[F, 0.0, 320.0], [0.0, F, 240.0], [0.0, 0.0, 1.0]])
DELTA = 1.4


def _pnp(T_o_c_guess, p_o, px):
    T_c_o = inv_T(T_o_c_guess)
    rvec, tvec = cv2.Rodrigues(T_c_o[:3, :3])[0], T_c_o[:3, 3].reshape(3, 1).copy()
    _, rvec, tvec = cv2.solvePnP(p_o.reshape(-1, 1, 3), px.reshape(-1, 1, 2), K, None, rvec, tvec,
                                 useExtrinsicGuess=True, flags=cv2.SOLVEPNP_ITERATIVE)
    rvec, tvec = cv2.solvePnPRefineLM(p_o.reshape(-1, 1, 3), px.reshape(-1, 1, 2), K, None, rvec, tvec)
    return inv_T(make_T(cv2.Rodrigues(rvec)[0], tvec.reshape(3)))


def _chain(n_frames=12, max_frames=200, seed=0):
    """A camera driving 1 m per frame while turning 2 deg per frame; 80 landmarks (4-60 m) born every second
    frame at raw stereo depths ``DELTA`` px short in disparity (long); each frame's pose fitted (PnP, exact
    pixels) on the raw landmarks, placed from the fitted birth poses, as the estimator chains them. Returns
    the record, the true and the fitted poses, the landmarks ``id -> (birth frame, p_c true, p_c raw)`` and
    a :class:`DisparityOffset` fed like the estimator's (births at the fitted centres)."""
    rng = np.random.default_rng(seed)
    rec, offset = ChainRecord(max_frames), DisparityOffset(OffsetConfig(), F, B)
    T_true, T_fit, lms = [], [], {}
    R, c = np.eye(3), np.zeros(3)
    for k in range(n_frames):
        if k:
            c = c + R @ np.array([0.0, 0.0, 1.0])
            R = R @ rot_y(np.deg2rad(2.0))
        T = make_T(R, c)
        T_true.append(T)
        ids = np.array(sorted(lms), np.int64)
        if k:
            p_c = transform_points(inv_T(T), np.array([transform_points(T_true[lms[i][0]], lms[i][1][None])[0]
                                                       for i in ids]))
            vis = (p_c[:, 2] > 1.0) & np.all(np.abs(p_c[:, :2] / p_c[:, 2:3]) < 0.8, axis=1)
            ids, p_c = ids[vis], p_c[vis]
            px = p_c[:, :2] / p_c[:, 2:3] * F + K[:2, 2]
            p_raw_o = np.array([transform_points(T_fit[lms[i][0]], lms[i][2][None])[0] for i in ids])
            T_fit.append(_pnp(T_fit[-1] @ inv_T(T_true[k - 1]) @ T, p_raw_o, px))
        else:
            T_fit.append(T.copy())
            px = np.zeros((0, 2))
        if k % 2 == 0:
            z = rng.uniform(4.0, 60.0, 80)
            p_true = np.c_[rng.uniform(-0.6, 0.6, (80, 2)) * [1.0, 0.3] * z[:, None], z]
            p_raw = p_true * (F * B / (F * B / z - DELTA) / z)[:, None]
            born = np.arange(1000 * k, 1000 * k + 80)
            rec.born(born, p_raw)
            dir_o = (T_fit[k][:3, :3] @ (p_raw / p_raw[:, 2:3]).T).T
            offset.add(born, T_fit[k][:3, 3], dir_o, p_raw[:, 2])
            for i, pt, pr in zip(born, p_true, p_raw):
                lms[int(i)] = (k, pt, pr)
        rec.frame(T_fit[k], ids, px)
    return rec, T_true, T_fit, lms, offset


def _pose_err(T_a, T_b):
    dR = T_a[:3, :3].T @ T_b[:3, :3]
    return np.linalg.norm(T_a[:3, 3] - T_b[:3, 3]), np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))


def test_replay_with_the_true_offset_recovers_the_true_chain():
    """Poses chained on depths long by the offset drift (the current pose here over 0.2 m off); re-chained with
    the true offset, every pose is the true one (exact pixels: to the solver's precision, 1e-6 m / 1e-8 rad)
    and the landmarks' raw points sit in their true birth cameras."""
    rec, T_true, T_fit, lms, _ = _chain()
    assert _pose_err(T_fit[-1], T_true[-1])[0] > 0.2
    replay = rec.replay(DELTA, F * B, K)
    assert len(replay.pairs) == len(T_true)
    for (T_old, T_new), T_f, T_t in zip(replay.pairs, T_fit, T_true):
        assert np.array_equal(T_old, T_f)
        dt, dr = _pose_err(T_new, T_t)
        assert dt < 1e-6 and dr < 1e-8
    for i, p_raw_o in replay.raw_o.items():
        k, _, p_raw = lms[i]
        assert np.allclose(p_raw_o, transform_points(T_true[k], p_raw[None])[0], atol=1e-6)


def test_replay_without_offset_keeps_the_chain():
    """Re-chained with no offset, the raw depths give back the poses they were fitted with (within 1e-5 m, LM's
    stopping tolerance from another start, against the 0.2 m the offset moves the chain): the replay moves the
    chain only by what the offset changes."""
    rec, _, T_fit, _, _ = _chain()
    replay = rec.replay(0.0, F * B, K)
    for (_, T_new), T_f in zip(replay.pairs, T_fit):
        dt, dr = _pose_err(T_new, T_f)
        assert dt < 1e-5 and dr < 1e-7


def test_offset_estimate_rebased_with_the_chain():
    """After the replay, the offset estimate's birth centres are the re-chained ones, so its depth correction
    of a landmark's re-chained raw point (the estimator's state) gives the true point."""
    rec, T_true, _, lms, offset = _chain()
    offset.delta_px = DELTA
    replay = rec.replay(DELTA, F * B, K)
    offset.rebase(replay.moved())
    for i, p_raw_o in replay.raw_o.items():
        k, p_true, _ = lms[i]
        assert np.allclose(offset.correct(i, p_raw_o), transform_points(T_true[k], p_true[None])[0], atol=1e-5)
    # the record now holds the re-chained poses: a second replay with the same offset moves nothing
    again = rec.replay(DELTA, F * B, K)
    for (T_old, T_new) in again.pairs:
        assert _pose_err(T_old, T_new)[0] < 1e-6


def test_record_bounded_and_disabled():
    """At most ``max_frames`` frames (the oldest kept one is the anchor and keeps its pose); 0 records nothing."""
    rec, _, T_fit, _, _ = _chain(max_frames=5)
    replay = rec.replay(DELTA, F * B, K)
    assert len(replay.pairs) == 5
    assert np.array_equal(replay.pairs[0][1], T_fit[-5])
    rec0, *_ = _chain(n_frames=4, max_frames=0)
    assert rec0.replay(DELTA, F * B, K) is None


@pytest.mark.parametrize("field", ["replay_frames", "replay_step_px"])
def test_config_checked(field):
    with pytest.raises(Exception, match=field):
        OffsetConfig.from_option({field: -1})


def _offset_run(ds, delta_px: float, replay_frames: int):
    """``klt-pnp`` on ``ds`` with every new landmark's stereo disparity ``delta_px`` short (its depth long), as a
    calibration with the right principal point off the images' gives, injected through the landmark source ->
    (estimator, poses (N,4,4))."""
    fb = float(ds.rig.cameras[0].K[0, 0]) * ds.rig.baseline
    est = None

    def source(left, right, ids, p_l):
        cfg = est.pnp_config
        p_r, ok = stereo_klt(left, right, p_l, ds.rig, est.klt_config, est.tracker.pyramid)
        p_c0, ok_t = triangulate(ds.rig, p_l, p_r, cfg.max_depth, cfg.max_triangulation_px)
        z = np.where(p_c0[:, 2] > 0, p_c0[:, 2], 1.0)
        d_raw = fb / z - delta_px
        ok = ok & ok_t & (d_raw > 0.5)
        return p_c0 * (fb / np.where(ok, d_raw, 1.0) / z)[:, None], ok

    est = KltPnpEstimator(ds.rig, landmark_source=source, disparity_offset={"replay_frames": replay_frames})
    return est, np.array([est.process(f).T_o_c0 for f in ds.frames()])


@pytest.mark.slow
def test_klt_pnp_rechains_its_start_up_on_rendered_frames(campus_short):
    """Rendered campus (6 s from rest, 3.3 m) with a 2 px disparity offset: the offset is estimated and applied
    (frame 50) either way; without the re-chaining the end point keeps the long steps of the frames before (measured
    0.147 m off the truth), re-chained it is 0.010 m off. Bounds: the offset within 0.3 px of 2 px (its fits
    from 3 m of travel), the re-chained end error below 0.04 m and below a third of the other."""
    ds = open_dataset(campus_short)
    gt = ds.groundtruth_cam0().T
    err = {}
    for replay_frames in (0, 200):
        est, T = _offset_run(ds, 2.0, replay_frames)
        assert est.offset.delta_px == pytest.approx(2.0, abs=0.3)
        g = np.linalg.inv(gt[0]) @ gt[len(T) - 1]
        err[replay_frames] = float(np.linalg.norm(T[-1][:3, 3] - g[:3, 3]))
    assert err[200] < 0.04 and err[200] < err[0] / 3
