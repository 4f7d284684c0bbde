"""``rop``'s online stereo disparity-offset estimate: the right principal point corrected from the tracks.

A written calibration whose right principal point is ``delta`` px off the images' makes every disparity
``delta`` px short (:mod:`vo.estimators.disparity_offset`). ``rop``'s ROPs hold the stereo relative
orientation fixed, so the offset bends the four-view geometry, and the track filter's stereo triangulation
(:mod:`vo.rop.moving`) puts far points much too far: near and far points then imply motions more than the
filter's 4 px apart, the filter sees "competing motions" in a static world, and the frames whose ROP step
disagrees with its (long) PnP step take that PnP pose (``urban-kitti-calib``, 3.0 px written: 27 of 781 frames,
6.0 % drift; docs/estimators.md, "The simulator's prediction").

The estimate is ``klt-pnp``'s (:class:`~vo.estimators.disparity_offset.DisparityOffset`, the same
:class:`~vo.estimators.disparity_offset.OffsetConfig` defaults, option ``rop.disparity_offset``), fed with
``rop``'s own tracks: every track is registered on the frame it is born (a keyframe's new corner, its raw
stereo depth and left ray at the estimator's pose) and observed on every later frame at its current left
point (``FourView.x3``) with the estimator's pose. The pose tracks of ``klt-pnp``'s guard are the track
filter's PnP inliers (:attr:`vo.rop.moving.TrackFilter.inliers`): an offset is applied only when the fits on
them alone pass the test too (``klt-pnp`` needs that guard against actors moving with the camera among its
kept outliers). It does not hold the early keyframes of ``urban-dynamic`` seed 0 (a consistent rig), whose fits
sit at the test's edge on the pose tracks as on all tracks (-0.39 px, se 0.10, at frame 102: applied on and off
for a few frames; docs/estimators.md, "``rop``: the same offset estimate"). Once an offset is applied, the
four-view tracker stores every new right-image match with the right principal point corrected by it
(:attr:`vo.rop.tracks.KltFourView.right_shift_px`), so the ROPs and the triangulations read the corrected
disparities; on a consistent rig nothing is applied and ``rop`` computes exactly what it does without the
estimate. Not in seed 000 (whose rig is calibrated): like ``klt-pnp``'s, an online self-calibration of
the one calibration parameter that the real KITTI turn showed to be off.
"""
from __future__ import annotations

import numpy as np

from vo.estimators.disparity_offset import DisparityOffset, OffsetConfig
from vo.frontend.stereo import triangulate
from vo.rop.tracks import KltFourView

MAX_DEPTH_M = 200.0      # birth depths beyond this are not registered (1.9 px disparity at KITTI's f b = 386 px m)


class RopOffset:
    """``RopOffset(rig, config)``: the estimate of one ``rop`` run. :meth:`frame` is called once per frame,
    after the pose is set, with the tracker's current :class:`~vo.rop.tracks.FourView`; :attr:`delta_px` is
    the offset to apply (0 until significant)."""

    def __init__(self, rig, config: OffsetConfig):
        cam = rig.cameras[0]
        self.rig, self.config = rig, config
        self.estimate = DisparityOffset(config, float(cam.fx), float(np.linalg.norm(rig.T_c0_c1[:3, 3])))
        self._last_id = -1       # tracks with a larger identity are born on the current frame
        self._pose_ids = None    # (M,) the tracks the track filter's PnP kept on this frame (None: no fit)

    def filtered(self, ids: np.ndarray, inliers: np.ndarray | None) -> None:
        """The track filter's verdict on this frame's tracks ``ids`` (N,): ``inliers`` (N,) bool, or None."""
        self._pose_ids = None if inliers is None else np.asarray(ids, np.int64)[inliers]

    @classmethod
    def of(cls, rig, option, tracker) -> "RopOffset | None":
        """The estimate for option ``rop.disparity_offset`` (:class:`OffsetConfig` or its fields; checked) when
        it is enabled and ``tracker`` is the KLT four-view tracker (whose stored right points it corrects); else
        None (another front-end, or a validation's exact tracks)."""
        config = OffsetConfig.from_option(option, "rop.disparity_offset")
        return cls(rig, config) if config.enabled and isinstance(tracker, KltFourView) else None

    @property
    def delta_px(self) -> float:
        return self.estimate.delta_px

    def frame(self, view, T_o_c0: np.ndarray, shift_px: float) -> float:
        """Register the tracks of ``view`` born on this frame (raw stereo depth: the stored right points
        ``p2`` plus the tracker's ``shift_px``) at pose ``T_o_c0`` (4,4), observe every track, and return the
        offset to apply from the next match on (px)."""
        if view is None or view.ids is None or len(view) == 0:
            return self.estimate.delta_px
        ids = np.asarray(view.ids, np.int64)
        est = self.estimate
        est.forget(ids)
        est.observe(ids, view.x3, T_o_c0, None if self._pose_ids is None else np.isin(ids, self._pose_ids))
        self._pose_ids = None
        born = ids > self._last_id
        if born.any():
            p_raw = view.p2[born] + np.array([shift_px, 0.0])
            p_c, ok = triangulate(self.rig, view.p1[born], p_raw, MAX_DEPTH_M, 1.0)
            if ok.any():
                z = p_c[ok, 2]
                dir_o = (p_c[ok] / z[:, None]) @ np.asarray(T_o_c0, float)[:3, :3].T
                est.add(ids[born][ok], T_o_c0[:3, 3], dir_o, z)
            self._last_id = int(ids.max())
        return est.delta_px
