"""A fisheye (equidistant) stereo dataset seen through ``cv2.fisheye`` rectification, for the estimators.

The estimators work on pinhole geometry (radtan undistortion, rectified stereo search). A dataset whose
cameras are equidistant is handed to them as :class:`RectifiedFisheyeView`: each frame is remapped with
:func:`rigs.rectify.stereo_rectify`'s maps (``cv2.fisheye.stereoRectify``, ``balance = 0``, and
``cv2.fisheye.initUndistortRectifyMap``, bilinear), the rig is the rectified pinhole pair, and
``groundtruth_cam0`` is the truth of the rectified left camera ``r0``: ``T_w_r0 = T_w_c0 [R0_rect^T | 0]``
(the same camera centre; for a parallel pair such as ``fisheye150`` ``R0_rect = I`` and ``r0 = c0``).
Everything else (IMU, GCPs, metadata, wheel ticks) is the dataset's own. Depth and segmentation stay
in the fisheye image and are not offered.
"""
from __future__ import annotations

import functools

import cv2
import numpy as np

from rigs.geometry import make_T
from rigs.rectify import stereo_rectify
from rigs.trajectory import Trajectory
from vo.dataset.base import rig_or_error
from vo.dataset.view import DatasetView
from rigs.records import StereoFrame
from vo.errors import DatasetError


def has_fisheye(dataset) -> bool:
    return any(getattr(c, "is_fisheye", False) for c in dataset.rig.cameras)


def for_estimators(dataset):
    """``dataset`` itself, or its :class:`RectifiedFisheyeView` when a camera is equidistant."""
    return RectifiedFisheyeView(dataset) if has_fisheye(dataset) else dataset


class RectifiedFisheyeView(DatasetView):
    """``dataset`` (a :class:`vo.dataset.base.Dataset` with equidistant cameras) with rectified pinhole frames."""

    images_are_rectified = True

    def __init__(self, dataset):
        super().__init__(dataset)
        self.rectification = rig_or_error(stereo_rectify, dataset.rig)
        self.rig = self.rectification.rectified_rig(dataset.rig)
        self._maps = self.rectification.maps(cv2.CV_32FC1)
        self.T_c0_r0 = make_T(self.rectification.R0_rect.T, np.zeros(3))

    def __repr__(self) -> str:
        return f"<RectifiedFisheyeView of {self._ds!r}>"

    def frame(self, k: int) -> StereoFrame:
        f = self._ds.frame(k)
        left, right = (cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
                       for img, (mx, my) in zip((f.left, f.right), self._maps))
        return StereoFrame(index=f.index, t_ns=f.t_ns, left=left, right=right)

    def groundtruth_cam0(self) -> Trajectory:
        """``T_w_r0`` (N,4,4) of the rectified left camera at the frame times."""
        gt = self._ds.groundtruth_cam0()
        return Trajectory(gt.t_ns, gt.T @ self.T_c0_r0, gt.ref, gt.frame)

    @functools.cached_property
    def groundtruth(self):
        return self._ds.groundtruth

    def depth(self, k: int, cam: int = 0) -> np.ndarray:
        raise DatasetError(f"{self._ds.path}: depth of a fisheye dataset is in the fisheye image; the rectified "
                           f"view the estimators get has none")
