"""Which tracks ``klt-pnp`` keeps after its PnP (``vo.estimators.track_gate``), against exact projections."""
from __future__ import annotations

import numpy as np

from rigs.geometry import make_T, rot_y, transform_points
from rigs.model import Camera
from vo.estimators.disparity_offset import OffsetConfig
from vo.estimators.track_gate import kept_tracks

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


def test_seed_003_rule_without_the_gate_or_the_offset_estimate():
    """Gate 0 (the default), or the offset estimate off: the PnP inliers only (seed 003 drops every outlier)."""
    T, p_o, px, off = _scene(1)
    inl = off == 0.0
    for cfg in (OffsetConfig(), OffsetConfig(track_gate_px=4.0, enabled=False)):
        assert np.array_equal(kept_tracks(T, p_o, px, inl, CAM, cfg), inl)
    behind = transform_points(T, np.array([[0.0, 0.0, -5.0]]))                 # a landmark behind the camera
    assert not kept_tracks(T, behind, np.array([[319.5, 239.5]]), np.array([False]), CAM,
                           OffsetConfig(track_gate_px=4.0))[0]
