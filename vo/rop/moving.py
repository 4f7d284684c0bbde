"""Moving objects in the ``rop`` front-end: keep the tracks of the rigid motion nearest the motion prior.

Our extension (seed 000 assumes a static scene; docs/estimators.md, "Moving objects"). The four ROPs see
every track; a car driving ahead at the vehicle's speed, or cross traffic while the vehicle waits, is a
rigid cluster that can outnumber the static background, and its tracks then set the essential matrices
(on ``urban-dynamic`` seed 0: 42 % of the four-view tracks on moving actors, steps of 1.8-36 m estimated
while the vehicle stands still). Before the ROPs, the keyframe stereo pairs ``(p1, p2)`` are triangulated
and the current left points ``p3`` give candidate rigid motions keyframe -> current frame
(:func:`vo.estimators.pnp_core.choose_motion`: up to ``max_models`` RANSAC fits in turn and the LM fit
from the prior). When two motions with at least ``min_model_fraction`` of the triangulated tracks are
different (:func:`~vo.estimators.pnp_core.separated`: enough tracks of one lie more than ``separation_px``
off the other), only the tracks of the one whose camera position is nearest the prior (the
constant-velocity prediction of the keyframe -> current pose) are kept, with the tracks too far to
triangulate (which constrain the rotation only and fit every translation). With one motion nothing changes. The pose itself still comes from the ROPs: the
point cloud only selects tracks.
"""
from __future__ import annotations

import numpy as np

from vo.estimators.pnp_core import PnpConfig, choose_motion
from vo.frontend.stereo import triangulate, undistort_px


def static_track_mask(view, rig, T_kf_c_prior: np.ndarray, config: PnpConfig) -> np.ndarray | None:
    """(N,) bool tracks of ``view`` (:class:`~vo.rop.tracks.FourView`) to keep, or None when the tracks
    hold a single rigid motion (nothing to choose)."""
    p_kf, tri = triangulate(rig, view.p1, view.p2, config.max_depth, config.max_triangulation_px)
    if tri.sum() < 2 * config.min_pnp_inliers:
        return None
    cam = rig.cameras[0]
    chosen = choose_motion(p_kf[tri], undistort_px(view.p3[tri], cam), cam.K, config, T_kf_c_prior)
    if chosen is None or not chosen[2]:
        return None
    inl = chosen[1]
    keep = ~tri
    keep[tri] = inl
    return keep
