"""Stereo rectification of a rig's cameras c0, c1 with OpenCV (``cv2.stereoRectify``).

OpenCV's ``R, T`` inputs map camera-1 points from camera 0: ``p_c1 = R p_c0 + T``, i.e.
``R = R_c1_c0`` and ``T = t_c1_c0`` (the inverse of our ``T_c0_c1``); :func:`opencv_stereo_RT`
does this conversion. Outputs: ``R0_rect = R_r0_c0`` and ``R1_rect = R_r1_c1`` rotate unrectified
camera points into the rectified frames ``r0``, ``r1`` (parallel axes, baseline along +x);
``P0 = K_rect [I | 0]``, ``P1 = K_rect [I | (-B, 0, 0)]`` so ``P1[0,3] = -fx_rect * B``.

A pair of equidistant (fisheye) cameras is rectified with ``cv2.fisheye.stereoRectify`` (``balance=0``:
the pinhole output keeps only valid pixels, so a 150 degree lens loses its periphery) and
``cv2.fisheye.initUndistortRectifyMap``; a pair mixing the two models is refused.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from rigs.errors import RigError
from rigs.model import Camera, Rig
from rigs.geometry.se3 import inv_T, make_T


def opencv_stereo_RT(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """Our ``T_c0_c1`` -> OpenCV's ``(R, T)`` = ``(R_c1_c0 (3,3), t_c1_c0 (3,))``."""
    T_c1_c0 = inv_T(rig.T_c0_c1)
    return T_c1_c0[:3, :3].copy(), T_c1_c0[:3, 3].copy()


@dataclass(frozen=True)
class Rectification:
    """Result of :func:`stereo_rectify`; arrays are float64, ``size`` is ``(width, height)``."""

    K_rect: np.ndarray     # (3,3) shared rectified intrinsics
    R0_rect: np.ndarray    # (3,3) R_r0_c0
    R1_rect: np.ndarray    # (3,3) R_r1_c1
    P0: np.ndarray         # (3,4) K_rect [I | 0]
    P1: np.ndarray         # (3,4) K_rect [I | (-B, 0, 0)]
    size: tuple            # (w, h) of the rectified images (= original size)
    cameras: tuple         # (Camera c0, Camera c1) the maps undistort with

    @property
    def baseline(self) -> float:
        """Rectified baseline ``-P1[0,3] / P1[0,0]`` (m)."""
        return float(-self.P1[0, 3] / self.P1[0, 0])

    def maps(self, m1type=cv2.CV_32FC1):
        """``((map0_x, map0_y), (map1_x, map1_y))`` for ``cv2.remap(img_k, *maps[k], INTER_LINEAR)``;
        each map is (h, w) float32 and gives, per rectified pixel, the source pixel in camera k."""
        out = []
        for cam, R, P in zip(self.cameras, (self.R0_rect, self.R1_rect), (self.P0, self.P1)):
            if cam.is_fisheye:
                out.append(cv2.fisheye.initUndistortRectifyMap(cam.K, cam.fisheye_coeffs, R, P, self.size, m1type))
            else:
                out.append(cv2.initUndistortRectifyMap(cam.K, cam.dist_coeffs, R, P, self.size, m1type))
        return tuple(out)

    def rectified_rig(self, rig: Rig) -> Rig:
        """Pinhole, distortion-free rig of the rectified cameras: ``T_b_rk = T_b_ck @ [R_rk_ck^T | 0]``."""
        w, h = self.size
        K = self.K_rect
        cams = []
        for k, R in enumerate((self.R0_rect, self.R1_rect)):
            T_b_r = rig.cameras[k].T_b_c_array @ make_T(R.T, np.zeros(3))
            cams.append(Camera(name=rig.cameras[k].name, width=w, height=h, fx=K[0, 0], fy=K[1, 1],
                               cx=K[0, 2], cy=K[1, 2], dist=(0.0,) * 5, T_b_c=T_b_r))
        return dataclasses.replace(rig, name=f"{rig.name}-rect", cameras=tuple(cams))


def stereo_rectify(rig: Rig) -> Rectification:
    """Rectify cameras 0 and 1 (``CALIB_ZERO_DISPARITY``, ``alpha=0``: crop to valid pixels,
    same image size as camera 0). Both cameras must have the same size."""
    if not rig.is_stereo:
        raise RigError(f"rig {rig.name!r}.cameras: stereo rectification needs two cameras, got one")
    c0, c1 = rig.cameras[0], rig.cameras[1]
    if (c0.width, c0.height) != (c1.width, c1.height):
        raise RigError(f"rig {rig.name!r}.cameras[1]: size {c1.width}x{c1.height} differs from "
                       f"cameras[0] {c0.width}x{c0.height}; rectification needs equal sizes")
    R, T = opencv_stereo_RT(rig)
    size = (c0.width, c0.height)
    if c0.is_fisheye != c1.is_fisheye:
        raise RigError(f"rig {rig.name!r}.cameras: cam0 is {c0.dist_model} and cam1 {c1.dist_model}; "
                       f"rectification needs one lens model for both")
    if c0.is_fisheye:
        R0, R1, P0, P1, _Q = cv2.fisheye.stereoRectify(
            c0.K, c0.fisheye_coeffs, c1.K, c1.fisheye_coeffs, size, R, T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY, newImageSize=size, balance=0.0, fov_scale=1.0)
        return Rectification(K_rect=P0[:, :3].copy(), R0_rect=R0, R1_rect=R1, P0=P0, P1=P1, size=size,
                             cameras=(c0, c1))
    R0, R1, P0, P1, _Q, _roi0, _roi1 = cv2.stereoRectify(
        c0.K, c0.dist_coeffs, c1.K, c1.dist_coeffs, size, R, T.reshape(3, 1),
        flags=cv2.CALIB_ZERO_DISPARITY, alpha=0.0, newImageSize=size)
    return Rectification(K_rect=P0[:, :3].copy(), R0_rect=R0, R1_rect=R1, P0=P0, P1=P1, size=size,
                         cameras=(c0, c1))
