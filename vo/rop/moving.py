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
off the other), only the tracks of the one whose camera position is nearest the prior are kept, with the
tracks too far to triangulate (which constrain the rotation only and fit every translation). With one
motion no track is dropped. The pose itself still comes from the ROPs: the point cloud selects tracks,
and its PnP pose (:attr:`TrackFilter.T_kf_c`) serves the estimator as the motion prior of the next
frame, as a cross-check of the ROP step and as the pose of a failed frame (:mod:`vo.rop.estimator`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs.geometry import inv_T
from vo.estimators.pnp_core import PnpConfig, choose_motion
from vo.frontend.stereo import triangulate, undistort_px

GROSS_STEP_FRACTION = 0.5     # one rigid motion: ROP and PnP steps of the same tracks differ by less than this


@dataclass(frozen=True)
class TrackFilter:
    """The track filter's verdict on one frame: ``keep`` (N,) bool tracks to keep, None for all of them
    (one rigid motion, or too few triangulated tracks to tell); ``T_kf_c`` the PnP pose keyframe -> current
    of the chosen motion (None without a fit); ``n_inliers`` its inliers (``inliers`` which tracks, None
    without a fit); ``prior_offset_m`` distance of its camera position from the prior's."""

    keep: np.ndarray | None
    T_kf_c: np.ndarray | None = None
    n_inliers: int = 0
    prior_offset_m: float = float("inf")
    inliers: np.ndarray | None = None    # (N,) bool: the tracks that are PnP inliers of the chosen motion

    def frame_pose(self, trusted_prior: bool, prior_gate_m: float, min_inliers: int) -> np.ndarray | None:
        """The PnP pose ``T_kf_c`` (4,4) when it may stand for the frame's: >= ``min_inliers`` inliers and, when
        the prior rests on a solved, not held pose (``trusted_prior``), within ``prior_gate_m`` of it (a car's
        motion as the only candidate, crossing traffic, is far from it). Else None."""
        if self.T_kf_c is None or self.n_inliers < min_inliers:
            return None
        return None if trusted_prior and self.prior_offset_m > prior_gate_m else self.T_kf_c

    def step_miss(self, T_kf_c: np.ndarray, T_pnp: np.ndarray | None, step_gate_m: float) -> str:
        """Why the ROP step ``T_kf_c`` is suspect ("" when it is not): the step lies farther from ``T_pnp``
        (:meth:`frame_pose`) than ``step_gate_m`` when competing rigid motions were seen (``keep`` set), or,
        with one rigid motion, farther than ``step_gate_m`` and :data:`GROSS_STEP_FRACTION` of the PnP step:
        both then fit the same tracks, so they differ by a scale error (8-16 % on a miscalibrated rig), never by
        the whole step (a gross ROP solution: 7.7 m against a 0.1 m motion before a blank wall indoors)."""
        if T_pnp is None:
            return ""
        d = float(np.linalg.norm(np.asarray(T_kf_c)[:3, 3] - T_pnp[:3, 3]))
        gate = step_gate_m if self.keep is not None else \
            max(step_gate_m, GROSS_STEP_FRACTION * float(np.linalg.norm(T_pnp[:3, 3])))
        return f"ROP step {d:.2f} m > {gate:.2f} m from the track filter's PnP pose" if d > gate else ""


def filter_tracks(view, rig, T_kf_c_prior: np.ndarray, config: PnpConfig) -> TrackFilter:
    """:class:`TrackFilter` of the tracks of ``view`` (:class:`~vo.rop.tracks.FourView`): every track
    triangulated from the keyframe pair ``(p1, p2)`` against its current left point ``p3`` (four-view or
    not), the motion nearest ``T_kf_c_prior`` (:func:`~vo.estimators.pnp_core.choose_motion`)."""
    p_kf, tri = triangulate(rig, view.p1, view.p2, config.max_depth, config.max_triangulation_px)
    if tri.sum() < 2 * config.min_pnp_inliers:
        return TrackFilter(None)
    cam = rig.cameras[0]
    chosen = choose_motion(p_kf[tri], undistort_px(view.p3[tri], cam), cam.K, config, T_kf_c_prior)
    if chosen is None:
        return TrackFilter(None)
    T_c_kf, inl, competing = chosen
    T_kf_c = inv_T(T_c_kf)
    offset = float(np.linalg.norm(T_kf_c[:3, 3] - np.asarray(T_kf_c_prior, float)[:3, 3]))
    inliers = np.zeros(len(tri), bool)
    inliers[tri] = inl
    keep = (~tri | inliers) if competing else None
    return TrackFilter(keep, T_kf_c, int(inl.sum()), offset, inliers)

