"""Which tracks ``klt-pnp`` keeps after its PnP (``vo.estimators.track_gate``), against exact projections."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from rigs.geometry import make_T, rot_y, transform_points
from rigs.model import Camera
from vo.dataset import open_dataset
from vo.estimators.disparity_offset import DisparityOffset, OffsetConfig
from vo.estimators.pnp import KltPnpEstimator
from vo.estimators.track_gate import OffsetOnlyTracks, kept_tracks
from vo.frontend.klt import KltTracker, stereo_klt
from vo.frontend.stereo import triangulate

CAM = Camera("cam0", 640, 480, 500, 500, 319.5, 239.5)


def _scene(seed=0):
    """A pose, 60 landmarks 4-40 m ahead, their exact pixels; then the landmarks moved so that they reproject
    0, 3 (within the 4 px gate) or 9 px (beyond it) off their tracked pixels -> (T, p_o, px, offsets px)."""
    rng = np.random.default_rng(seed)
    T = make_T(rot_y(np.radians(10.0)), [0.3, 0.0, 2.0])
    z = rng.uniform(4.0, 40.0, 60)
    p_c = np.c_[rng.uniform(-0.5, 0.5, (60, 2)) * z[:, None], z]
    px = (CAM.K @ (p_c / z[:, None]).T).T[:, :2]
    off = np.repeat([0.0, 3.0, 9.0], 20)
    p_c_moved = p_c + np.c_[off * z / CAM.fx, np.zeros(60), np.zeros(60)]      # shifted sideways by `off` px
    return T, transform_points(T, p_c_moved), px, off


def test_outliers_near_the_pose_stay_tracks():
    """PnP inliers: the exact ones. The 3 px ones (as a 0.45 px disparity offset makes after 6 baselines of
    travel) stay tracks with a 4 px gate; the 9 px ones leave."""
    T, p_o, px, off = _scene()
    inl = off == 0.0
    kept = kept_tracks(T, p_o, px, inl, CAM, OffsetConfig(track_gate_px=4.0))
    assert np.array_equal(kept, off < 4.0)
    assert OffsetConfig().track_gate_px == 4.0                                   # the default


def test_seed_003_rule_without_the_gate_or_the_offset_estimate():
    """Gate 0, or the offset estimate off: the PnP inliers only (seed 003 drops every outlier)."""
    T, p_o, px, off = _scene(1)
    inl = off == 0.0
    for cfg in (OffsetConfig(track_gate_px=0.0), OffsetConfig(track_gate_px=4.0, enabled=False)):
        assert np.array_equal(kept_tracks(T, p_o, px, inl, CAM, cfg), inl)
    behind = transform_points(T, np.array([[0.0, 0.0, -5.0]]))                 # a landmark behind the camera
    assert not kept_tracks(T, behind, np.array([[319.5, 239.5]]), np.array([False]), CAM,
                           OffsetConfig(track_gate_px=4.0))[0]


def test_offset_only_tracks_leave_the_pose_input_until_they_leave():
    """The kept outliers (3 px off) are recorded as offset-only: masked out of the next PnP input and of the
    re-chaining record; an inlier never is; all clear again when every kept track is an inlier."""
    T, p_o, px, off = _scene(2)
    ids = np.arange(100, 160)
    inl = off == 0.0
    tracks = OffsetOnlyTracks()
    assert tracks.pose_mask(ids) is None
    kept = tracks.keep(ids, inl, kept_tracks(T, p_o, px, inl, CAM, OffsetConfig(track_gate_px=4.0)))
    assert np.array_equal(kept, off < 4.0)
    assert np.array_equal(tracks.pose_mask(ids), off != 3.0)
    ids_p, px_p = tracks.pose_tracks(ids, px)
    assert np.array_equal(ids_p, ids[off != 3.0]) and np.array_equal(px_p, px[off != 3.0])
    tracks.keep(ids, inl, inl)
    assert tracks.pose_mask(ids) is None
    # only the outliers a later offset fit reads (landmarks of keyframes not fitted yet) stay
    kept = tracks.keep(ids, inl, off < 4.0, pending=ids[:30])
    assert np.array_equal(kept, inl | ((off == 3.0) & (np.arange(60) < 30)))
    assert tracks.ids == set(range(120, 130))


class _RecordingOffset(DisparityOffset):
    """The product's estimate, recording the track ids it observes each frame."""

    def __init__(self, *args):
        super().__init__(*args)
        self.seen: list = []

    def observe(self, ids, x_n, T_o_c0, pose=None):
        self.seen.append({int(i) for i in ids})
        super().observe(ids, x_n, T_o_c0, pose)


class _RecordingKltPnp(KltPnpEstimator):
    """``klt-pnp`` recording, per frame, the track ids it hands the PnP solver, those it keeps for the offset
    only, and those the offset estimate observes."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.frame, self.pnp_ids, self.kept_for_offset = 0, {}, {}

    def process(self, frame):
        self.frame += 1
        return super().process(frame)

    def _pnp(self, p_o, px_raw, timings, use=None):
        ids = self.tracker.ids
        self.pnp_ids[self.frame] = {int(i) for i in (ids if use is None else ids[use])}
        return super()._pnp(p_o, px_raw, timings, use)

    def _update_offset(self):
        only, n_seen = set(self._offset_only.ids), len(self.offset.seen)
        super()._update_offset()
        assert len(self.offset.seen) == n_seen + 1
        self.kept_for_offset[self.frame] = (only, self.offset.seen[-1])


@pytest.mark.slow
def test_near_outliers_reach_the_offset_estimate_but_never_the_pnp(campus_short):
    """Rendered campus (6 s) with every landmark's disparity 1.5 px short (a calibration error, injected through
    the landmark source) and a 4 px track gate: the PnP outliers within the gate exist (the offset makes them),
    the offset estimate observes every one of them on the frame they are kept, and no later frame's PnP input
    holds one of them while it is kept."""
    ds = open_dataset(campus_short)
    rig = ds.rig
    fb = float(rig.cameras[0].K[0, 0]) * rig.baseline
    cfg = OffsetConfig(track_gate_px=4.0)
    est = None

    def source(left, right, ids, p_l):
        p_r, ok = stereo_klt(left, right, p_l, rig, est.klt_config, est.tracker.pyramid)
        p_c0, ok_t = triangulate(rig, p_l, p_r, est.pnp_config.max_depth, est.pnp_config.max_triangulation_px)
        z = np.where(p_c0[:, 2] > 0, p_c0[:, 2], 1.0)
        d_raw = fb / z - 1.5
        ok = ok & ok_t & (d_raw > 0.5)
        return p_c0 * (fb / np.where(ok, d_raw, 1.0) / z)[:, None], ok

    offset = _RecordingOffset(cfg, float(rig.cameras[0].K[0, 0]), rig.baseline)
    est = _RecordingKltPnp(rig, landmark_source=source, disparity_offset=cfg, offset=offset)
    for f in ds.frames():
        est.process(f)
    n_kept = 0
    for k, (only, seen) in est.kept_for_offset.items():
        n_kept += len(only)
        assert only <= seen                                    # observed on the frame they are kept
        assert not only & est.pnp_ids.get(k + 1, set())        # never handed to the next frame's PnP
    assert n_kept > 0


def test_offset_only_tracks_are_invisible_to_detection_and_the_keyframe_rule():
    """On a textured image: with half the tracks offset-only, a keyframe's detection fills their cells exactly as
    if they were gone (the same new corners), keeps them tracked where they were, and the empty-cell fraction of
    the keyframe rule counts the pose tracks only."""
    img = cv2.GaussianBlur(np.random.default_rng(3).integers(0, 255, (240, 320)).astype(np.uint8), (3, 3), 0)
    tracker, alone = KltTracker(320, 240), KltTracker(320, 240)
    ids = tracker.detect(img)
    assert len(ids) > 20
    only = np.arange(len(ids)) % 2 == 1
    tracks = OffsetOnlyTracks()
    tracks.keep(ids, ~only, np.ones(len(ids), bool))
    alone.pts = tracker.pts[~only].copy()
    assert tracks.empty_fraction(tracker) == alone.empty_fraction > tracker.empty_fraction
    pts_only = tracker.pts[only].copy()
    new = tracks.detect(tracker, img)
    alone.detect(img)
    assert len(new) == only.sum()
    assert np.array_equal(tracker.pts[np.isin(tracker.ids, new)], alone.pts[-len(new):])
    assert np.array_equal(tracker.pts[np.isin(tracker.ids, ids[only])], pts_only)
