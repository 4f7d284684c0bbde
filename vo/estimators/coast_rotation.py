"""The rotation of a frame whose pose is coasted: a rotation-only fit of the frame-to-frame tracks.

Our extension (seed 003 has no failure policy). When a stereo PnP estimator cannot fit a pose (too few
tracked landmarks, PnP failure, too few stereo landmarks to re-initialise), it coasts: constant velocity,
the last measured step repeated. In a turn that is the rotation of the frame before, so a turn that speeds up
in front of a texture-poor view is under-turned by the whole acceleration (``indoor-realistic`` seed 0,
frames 227-234: 2.0 degrees per frame held where the cart turns 2.5-4.9; docs/estimators.md, "Photometric
robustness"). The tracks that survive from the previous frame still measure the rotation: over one frame
the camera's translation is small against the scene's depth, so the bearings of the tracks obey
``b_cur ~ R_cur_prev b_prev`` and :func:`vo.rop.rotation_only.rotation_only` (Kabsch with one robust refit,
the fit ``rop`` uses for its failed frames) gives ``R_prev_cur``. The coasted step then takes that rotation
and the constant-velocity translation. At least :data:`vo.rop.rotation_only.MIN_ROTATION_TRACKS` tracks (as ``rop``); fewer give
no rotation (None), and the step is the constant-velocity one.
"""
from __future__ import annotations

import numpy as np

from rigs.geometry.pinhole import to_normalized
from vo.frontend.stereo import undistort_px
from vo.rop.rotation_only import MIN_ROTATION_TRACKS, rotation_only


def coast_rotation(p_prev: np.ndarray, p_cur: np.ndarray, cam) -> np.ndarray | None:
    """``R_prev_cur`` (3,3), the rotation of the current left camera in the previous one, from the raw pixels
    ``p_prev`` (N,2) and ``p_cur`` (N,2) of the same tracks in the left images of the two frames (``cam`` the
    left :class:`~rigs.model.Camera`); None for fewer than :data:`MIN_ROTATION_TRACKS` tracks."""
    p_prev = np.asarray(p_prev, float).reshape(-1, 2)
    p_cur = np.asarray(p_cur, float).reshape(-1, 2)
    if len(p_prev) < MIN_ROTATION_TRACKS:
        return None
    K = np.asarray(cam.K, float)
    x_prev = to_normalized(undistort_px(p_prev, cam), K)
    x_cur = to_normalized(undistort_px(p_cur, cam), K)
    R_prev_cur, _, _ = rotation_only(x_prev, x_cur, float(np.mean(np.diag(K)[:2])))
    return R_prev_cur
