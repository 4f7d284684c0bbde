"""Which tracks ``klt-pnp`` keeps after a frame's PnP: its inliers, and the outliers still near the pose.

Seed 003 drops every PnP outlier from the tracks. Under a calibration whose disparity is off, that rule selects:
a landmark placed at a depth the offset made wrong reprojects off the fitted pose by about ``delta t / b`` px
after a sideways travel ``t`` (``b`` the baseline; the same at every depth), 2.7 px for a 0.45 px offset after
the 6 baselines that the online offset estimate waits for (:mod:`vo.estimators.disparity_offset`), so the PnP's
2 px inlier gate removes exactly the landmarks that carry the offset, and the estimate, fitted on the survivors,
falls short of it: on the real KITTI turn 0.79 / 1.17 / 1.42 px with a 1 / 2 / 4 px PnP gate, on
``campus-realistic`` seed 0 (not applied) 0.27 / 0.29 / 0.40 px for the rig's 0.45 px (docs/estimators.md).
Keeping, as tracks, the outliers within ``track_gate_px`` (4 px, twice the inlier gate, was measured) of the
fitted pose lets the estimate see them. They are kept for the estimate only
(:class:`OffsetOnlyTracks`): KLT tracks them and the estimate observes them, but nothing that defines the pose
sees them: not that frame's pose (PnP already chose its inliers), nor any later PnP input, the re-chaining record
(:mod:`vo.estimators.offset_replay`), the keyframe rule's empty cells, new-corner detection, the ``min_features``
count, the coasting rotation or the stereo prior; each frame they are tested against the new pose and leave
beyond the gate, or once their birth keyframe has been fitted (no later fit reads them). Where no offset is
applied the trajectory is therefore that of gate 0. Kept as ordinary tracks instead (the next PnP testing them
again), they made the PnP's consensus search fit more candidate motions, 28-33 ms CPU per frame on
``campus-realistic`` against the 20 ms budget; kept for the estimate only they cost 0.6-1.2 ms (tracking them,
larger offset fits; docs/estimators.md). ``track_gate_px`` 0 (or the offset estimate off) drops every outlier,
as seed 003 does. In traffic the outliers near the pose include landmarks on actors moving with the camera,
which the fit reads as depths too long: on a consistent rig (``urban-dynamic`` seed 0, full route) the estimate
with them reached -0.84 px at frame 100 and -0.36 px at frame 600, applied, drift 3.87 -> 10.45 %. So the pose
tracks alone decide whether an offset is applied (:meth:`DisparityOffset._update`: their own fits must pass the
test too) and the kept outliers only sharpen its value: ``urban-dynamic`` 0 stays at 3.87 %, the real KITTI
turn goes 2.58 -> 0.55 % (docs/estimators.md).
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T, transform_points
from rigs.geometry.pinhole import project
from vo.frontend.stereo import undistort_px


def kept_tracks(T_o_c0: np.ndarray, p_o: np.ndarray, px_raw: np.ndarray, inliers: np.ndarray, cam,
                config) -> np.ndarray:
    """(N,) bool: the PnP ``inliers`` (N,) and the tracks whose landmark ``p_o`` (N,3) reprojects, at the fitted
    pose ``T_o_c0`` (4,4), within ``config.track_gate_px`` (an :class:`~vo.estimators.disparity_offset.OffsetConfig`)
    of its tracked raw pixel ``px_raw`` (N,2) (undistorted with ``cam``, a :class:`~rigs.model.Camera`) in front
    of the camera; only the inliers where the gate is 0 or the offset estimate is off."""
    inliers = np.asarray(inliers, bool)
    gate_px = config.track_gate_px if config.enabled else 0.0
    if gate_px <= 0 or len(inliers) == 0:
        return inliers
    p_c = transform_points(inv_T(T_o_c0), np.asarray(p_o, float).reshape(-1, 3))
    z = p_c[:, 2]
    uv = project(np.column_stack([p_c[:, :2], np.where(z > 0, z, 1.0)]), np.asarray(cam.K, float))
    res = np.linalg.norm(uv - undistort_px(np.asarray(px_raw, float).reshape(-1, 2), cam), axis=1)
    return inliers | ((z > 0) & (res < gate_px))


class OffsetOnlyTracks:
    """The tracks kept for the disparity-offset estimate only: the PnP outliers that :func:`kept_tracks` kept.
    KLT goes on tracking them and the offset estimate observes them, but they are left out of every later
    frame's PnP input (and of the re-chaining record that refits poses), so nothing that defines the pose sees
    them; one that moves beyond the gate of a later pose leaves the tracks."""

    def __init__(self):
        self.ids: set = set()

    def reset(self) -> None:
        self.ids.clear()

    def pose_mask(self, ids) -> np.ndarray | None:
        """(N,) bool: which of the tracks ``ids`` (N,) may define the pose; None when all may."""
        if not self.ids:
            return None
        return ~np.isin(np.asarray(ids, np.int64), np.fromiter(self.ids, np.int64, len(self.ids)))

    def keep(self, ids, inliers: np.ndarray, kept: np.ndarray, pending=None) -> np.ndarray:
        """Record, of the tracks ``ids`` (N,), the ``kept`` (N,) bool ones that are not PnP ``inliers`` (N,) as
        offset-only, only those among ``pending`` ids (the landmarks a later offset fit reads; default: all);
        returns the tracks to keep: the inliers and the offset-only ones."""
        ids = np.asarray(ids, np.int64)
        extra = np.asarray(kept, bool) & ~np.asarray(inliers, bool)
        if pending is not None:
            extra &= np.isin(ids, pending)
        self.ids = {int(i) for i in ids[extra]}
        return np.asarray(inliers, bool) | extra

    def pose_all(self, ids) -> np.ndarray:
        """(N,) bool: which of the tracks ``ids`` (N,) may define the pose (all True when all may)."""
        use = self.pose_mask(ids)
        return np.ones(len(ids), bool) if use is None else use

    def pose_tracks(self, ids, px) -> tuple:
        """The tracks ``ids`` (N,) and their pixels ``px`` (N,2) that may define the pose."""
        return self.pose_rows(ids, ids, px)

    def pose_rows(self, ids, *arrays) -> tuple:
        """Each of ``arrays`` ((N, ...) each, one row per track of ``ids`` (N,)) at the tracks that may define the
        pose."""
        use = self.pose_mask(ids)
        return arrays if use is None else tuple(np.asarray(a)[use] for a in arrays)

    def detect(self, tracker, img) -> np.ndarray:
        """``tracker.detect(img)`` (a :class:`~vo.frontend.klt.KltTracker`) as if the offset-only tracks were
        not there: new corners fill the cells those hold too; returns the new ids."""
        use = self.pose_mask(tracker.ids)
        if use is None:
            return tracker.detect(img)
        pts_only, ids_only = tracker.pts[~use], tracker.ids[~use]
        tracker.keep(use)
        new_ids = tracker.detect(img)
        tracker.append(pts_only, ids_only)
        return new_ids

    def empty_fraction(self, tracker) -> float:
        """The tracker's empty-cell fraction (the keyframe rule's) counting the pose tracks only."""
        use = self.pose_mask(tracker.ids)
        return tracker.empty_fraction if use is None else tracker.grid.empty_fraction(tracker.pts[use])
