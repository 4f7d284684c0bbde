"""Lens distortion as an image warp: render a pinhole canvas, remap it to the distorted image.

For every pixel ``(u_d, v_d)`` of the distorted image we need the undistorted pixel it came from.
OpenCV's model maps normalised undistorted ``x_n`` to distorted ``x_d = D(x_n)``
(``k1, k2, p1, p2, k3``); we invert it per pixel exactly (:func:`rigs.geometry.pinhole.undistort_exact`:
Newton's method on the analytic 2x2 Jacobian) and check the result by re-distorting with
``cv2.projectPoints``: the maps are rejected (``SimError``) if any pixel is off by >= 1e-3 px.

The canvas is the pinhole camera with the same ``fx, fy`` and a shifted principal point
``(cx - u0, cy - v0)``, sized to hold every source location plus a 2 px border (barrel distortion
needs pixels outside the distorted frame's pinhole footprint). ``cv2.remap`` uses fixed-point
interpolation weights (1/32 px), so the resampled position is exact to <= 1/64 px.

Equidistant (fisheye, ``dist_model: equidistant``) cameras take the same path: the source of each
fisheye pixel is ``cv2.fisheye.undistortPoints`` (checked by ``cv2.fisheye.projectPoints``, same
1e-3 px bound). A pinhole canvas only holds rays less than 90 degrees off its axis, and its half-size
grows as ``f tan(theta)``: :func:`fisheye_needed_theta` finds the widest ray the image needs, and rays
beyond :data:`MAX_FISHEYE_THETA_DEG` (80 degrees, a 160 degree field of view; the canvas is then 11.3 f
across) or a canvas side over :data:`MAX_CANVAS_SIDE_PX` are refused with a ``SimError``. A 150 degree
(diagonal) fisheye, theta = 75 degrees at the corners, needs a canvas 2 f tan(75) = 7.5 f across the
diagonal: 1892x1420 px for the 640x480 ``fisheye150`` preset (f = 315 px), 8x the output's pixels.
Lenses of 180 degrees or more (e.g. 163-173 degree tracking cameras) would need several pinhole
renders (a cube map) and are not supported.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from rigs.geometry import pinhole
from rigs.model import Camera
from sim.errors import SimError

MAX_REPROJ_PX = 1e-3
_BORDER_PX = 2
MAX_FISHEYE_THETA_DEG = 80.0
MAX_CANVAS_SIDE_PX = 4096


def fisheye_needed_theta(camera: Camera) -> float:
    """Largest angle [rad] off the optical axis among the rays of an equidistant camera's image
    (its four corners). A SimError when the lens needs rays beyond :data:`MAX_FISHEYE_THETA_DEG`, or
    its ``theta_d(theta)`` is not increasing up to there (the model would fold the image)."""
    lim = math.radians(MAX_FISHEYE_THETA_DEG)
    th = np.linspace(0.0, lim, 2001)[1:]
    rays = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], axis=1)
    theta_d = (camera.project(rays)[:, 0] - camera.cx) / camera.fx       # normalised distorted radius
    if not np.all(np.diff(theta_d) > 0):
        raise SimError(f"distortion: camera {camera.name!r} dist={camera.dist}: the equidistant model is not "
                       f"increasing up to {MAX_FISHEYE_THETA_DEG:g} degrees off axis (it folds the image)")
    corners = np.array([[0, 0], [camera.width - 1, 0], [0, camera.height - 1],
                        [camera.width - 1, camera.height - 1]], dtype=float)
    r_d = np.hypot((corners[:, 0] - camera.cx) / camera.fx, (corners[:, 1] - camera.cy) / camera.fy).max()
    if r_d >= theta_d[-1]:
        raise SimError(f"distortion: camera {camera.name!r}: its image corners see rays more than "
                       f"{MAX_FISHEYE_THETA_DEG:g} degrees off axis (a field of view over "
                       f"{2 * MAX_FISHEYE_THETA_DEG:g} degrees); one pinhole render holds less than 180 degrees "
                       f"and this renderer at most {2 * MAX_FISHEYE_THETA_DEG:g}: lower the field of view "
                       f"(raise fx, fy or crop the image)")
    return float(np.interp(r_d, theta_d, th))


def undistort_exact(uv_d: np.ndarray, camera: Camera, iters: int = 30) -> np.ndarray:
    """(N,2) distorted pixels -> (N,2) normalised undistorted coordinates (exact inverse,
    :func:`rigs.geometry.pinhole.undistort_exact`)."""
    return pinhole.undistort_exact(uv_d, camera.K, camera.dist_coeffs, iters=iters)


def reprojection_error_px(xy: np.ndarray, uv_d: np.ndarray, camera: Camera) -> np.ndarray:
    """(N,) pixel distance between ``cv2.projectPoints`` of normalised ``xy`` and ``uv_d``."""
    pts = np.concatenate([xy, np.ones((len(xy), 1))], axis=1)
    return np.linalg.norm(camera.project(pts) - uv_d, axis=1)


class DistortionMap:
    """Precomputed remap from the pinhole canvas (``canvas_camera``) to ``camera``'s distorted image."""

    def __init__(self, camera: Camera):
        self.camera = camera
        W, H = camera.width, camera.height
        v, u = np.mgrid[0:H, 0:W].astype(np.float64)
        uv_d = np.stack([u.ravel(), v.ravel()], axis=1)
        if camera.is_fisheye:
            fisheye_needed_theta(camera)
            xy = camera.undistort_normalized(uv_d)
            err = reprojection_error_px(xy, uv_d, camera)
            if not np.all(np.isfinite(err)) or err.max() >= MAX_REPROJ_PX:
                raise SimError(f"distortion: camera {camera.name!r} equidistant dist={camera.dist}: inverse not "
                               f"exact (max re-projection error {np.nanmax(err):.2e} px >= {MAX_REPROJ_PX} px)")
        elif camera.has_distortion:
            xy = undistort_exact(uv_d, camera)
            err = reprojection_error_px(xy, uv_d, camera)
            if not np.all(np.isfinite(err)) or err.max() >= MAX_REPROJ_PX:
                raise SimError(f"distortion: camera {camera.name!r} dist={camera.dist}: inverse not exact "
                               f"(max re-distortion error {np.nanmax(err):.2e} px >= {MAX_REPROJ_PX} px)")
        else:
            xy = pinhole.to_normalized(uv_d, camera.K)
        u_s, v_s = pinhole.to_pixels(xy, camera.K).T      # source pixel in the full pinhole plane
        self.u0 = math.floor(u_s.min()) - _BORDER_PX
        self.v0 = math.floor(v_s.min()) - _BORDER_PX
        cw = math.ceil(u_s.max()) + _BORDER_PX + 1 - self.u0
        ch = math.ceil(v_s.max()) + _BORDER_PX + 1 - self.v0
        if max(cw, ch) > MAX_CANVAS_SIDE_PX:
            raise SimError(f"distortion: camera {camera.name!r}: its pinhole canvas would be {cw}x{ch} px "
                           f"(over {MAX_CANVAS_SIDE_PX} px a side); lower the field of view or the resolution")
        self.canvas_camera = Camera(f"{camera.name}", cw, ch, camera.fx, camera.fy,
                                    camera.cx - self.u0, camera.cy - self.v0,
                                    dist=(0, 0, 0, 0, 0), T_b_c=camera.T_b_c)
        self.map_x = (u_s - self.u0).reshape(H, W).astype(np.float32)
        self.map_y = (v_s - self.v0).reshape(H, W).astype(np.float32)

    def _check(self, img: np.ndarray) -> None:
        c = self.canvas_camera
        if img.shape[:2] != (c.height, c.width):
            raise SimError(f"distortion: camera {self.camera.name!r}: expected a canvas of "
                           f"{c.height}x{c.width}, got {img.shape[:2]}")

    def apply(self, img: np.ndarray) -> np.ndarray:
        """Canvas image (h,w[,3]) -> distorted image (H,W[,3]), bilinear."""
        self._check(img)
        return cv2.remap(img, self.map_x, self.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def apply_depth(self, depth: np.ndarray) -> np.ndarray:
        """Canvas depth (h,w) -> distorted (H,W), nearest neighbour (z is shared: same rotation)."""
        self._check(depth)
        return cv2.remap(depth, self.map_x, self.map_y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)

    def apply_seg(self, seg: np.ndarray) -> np.ndarray:
        """Canvas segmentation (h,w,2) int32 -> distorted (H,W,2), nearest neighbour."""
        self._check(seg)
        chans = [cv2.remap(np.ascontiguousarray(seg[..., i]).astype(np.float32), self.map_x, self.map_y,
                           cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE) for i in range(seg.shape[2])]
        return np.stack(chans, axis=2).astype(np.int32)


def canvas_rig(rig, maps) -> "object":
    """The rig to *render* with: each camera replaced by its map's pinhole canvas camera."""
    from dataclasses import replace
    return replace(rig, cameras=tuple(m.canvas_camera for m in maps))
