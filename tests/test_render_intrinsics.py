"""Camera conventions: a marker at a known 3-D point lands where OpenCV projects it.

The rig has fx != fy, a principal point off the centre by (+23.3, -17.1) px and cameras rotated
(pitch, yaw, roll) in the body; the vehicle pose is a general rotation + translation.
"""
from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from test_render_support import RenderTestScene, stereo_rig
from sim import mjcam
from sim.world import build_world
from sim.render import StereoRenderer
from rigs.geometry import inv_T, make_T, rot_x, rot_y, rot_z, transform_points

T_W_B = make_T(rot_z(0.6) @ rot_y(0.03) @ rot_x(-0.02), [2.0, -1.0, 0.2])
RADIUS = 0.2     # 5-9 px disc: centroid quantisation (no MSAA) measured <= 0.14 px
# Marker positions in the left camera frame: centre, off-centre in all four quadrants.
P_C0 = [(0.0, 0.0, 4.0), (0.55, -0.3, 4.0), (-0.6, 0.35, 4.5), (0.4, 0.45, 3.5)]


def _hi_res_spheres(spec):
    spec.visual.quality.numslices = 96   # finer sphere tessellation: silhouette error << 0.05 px
    spec.visual.quality.numstacks = 96


def _centroid(img: np.ndarray) -> np.ndarray:
    """(u, v) intensity centroid, OpenCV pixel convention (pixel centres at integers)."""
    w = img.astype(np.float64).sum(axis=2) if img.ndim == 3 else img.astype(np.float64)
    v, u = np.mgrid[0:w.shape[0], 0:w.shape[1]]
    return np.array([(w * u).sum(), (w * v).sum()]) / w.sum()


def _sphere_image_centre(p_c: np.ndarray, r: float, cam) -> np.ndarray:
    """Centre of the exact elliptical silhouette of a sphere (centre p_c, radius r), in pixels.

    Silhouette cone: x^T (c c^T - (|c|^2 - r^2) I) x = 0 with x = (x_n, y_n, 1); the ellipse
    centre solves the upper-left 2x2 block against minus the last column. It differs from the
    projection of p_c by O((r/|c|)^2) x offset: reported so the tolerance stays honest.
    """
    C = np.outer(p_c, p_c) - (p_c @ p_c - r * r) * np.eye(3)
    x0 = np.linalg.solve(C[:2, :2], -C[:2, 2])
    return np.array([cam.fx * x0[0] + cam.cx, cam.fy * x0[1] + cam.cy])


def _marker_world(rig, p_c0):
    return transform_points(T_W_B @ rig.cameras[0].T_b_c_array, np.array([p_c0]))[0]


def _render_marker(rig, p_w, distort=True):
    """Both cameras' images; a rig with lens distortion is rendered through DistortionMap
    (pinhole canvas + exact inverse remap) by build_world/StereoRenderer themselves."""
    scene = RenderTestScene(ground=False, wall_x=None, lit=False, markers=[("marker", p_w, RADIUS)])
    world = build_world(scene, rig, extra=_hi_res_spheres, distort=distort)
    with StereoRenderer(world) as r:
        return r.render(T_W_B).images


def test_mjcam_frame_conversion():
    R_b_c = np.array([[0.0, 0, 1], [-1, 0, 0], [0, -1, 0]])
    T_b_mj = mjcam.T_b_mjcam(make_T(R_b_c, [0.1, 0.2, 1.2]))
    # MuJoCo camera looks along its -z: -z_mj must be the optical axis (body +x); y_mj is up.
    np.testing.assert_allclose(-T_b_mj[:3, 2], [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(T_b_mj[:3, 1], [0, 0, 1], atol=1e-15)
    pos, q = mjcam.pos_quat_from_T(T_b_mj)
    np.testing.assert_allclose(mjcam.T_from_pos_quat(pos, q), T_b_mj, atol=1e-12)
    np.testing.assert_allclose(mjcam.T_b_cv(T_b_mj), make_T(R_b_c, [0.1, 0.2, 1.2]), atol=1e-15)


def test_mj_camera_intrinsics_values():
    cam = stereo_rig().cameras[0]
    a = mjcam.mj_camera_intrinsics(cam)
    assert a["resolution"] == [160, 120] and a["focal_pixel"] == [150.0, 130.0]
    np.testing.assert_allclose(a["principal_pixel"], [79.5 - 103.3, 59.5 - 42.9])


@pytest.mark.parametrize("p_c0", P_C0)
def test_marker_projects_to_opencv_pixel(p_c0):
    rig = stereo_rig()
    p_w = _marker_world(rig, p_c0)
    imgs = _render_marker(rig, p_w)
    for cam, img in zip(rig.cameras, imgs):
        p_c = transform_points(inv_T(T_W_B @ cam.T_b_c_array), p_w[None])[0]
        uv, _ = cv2.projectPoints(p_c[None], np.zeros(3), np.zeros(3), cam.K, np.zeros(5))
        uv = uv.ravel()
        # Silhouette-centre bias of a 0.2 m sphere at >= 3.5 m: < 0.1 px (exact conic centre).
        assert np.linalg.norm(_sphere_image_centre(p_c, RADIUS, cam) - uv) < 0.1
        # 0.25 px: a rasterised disc without MSAA has centroid quantisation <= 0.14 px here
        # (with 16x MSAA the residual drops to <= 0.07 px, no bias: the convention is exact);
        # a half-pixel convention error (0.5 px) or a wrong sign (>= 40 px) fails.
        assert np.linalg.norm(_centroid(img) - uv) < 0.25, (cam.name, _centroid(img), uv)


@pytest.mark.parametrize("p_c0", [(1.2, -0.9, 4.0), (-1.6, 0.9, 4.0)])   # far from (cx, cy)
def test_marker_projects_with_distortion(p_c0):
    dist = (-0.3, 0.09, 4e-4, -3e-4, 0.0)       # EuRoC-like barrel distortion
    rig = stereo_rig(dist=dist)
    p_w = _marker_world(rig, p_c0)
    imgs = _render_marker(rig, p_w)
    for cam, img in zip(rig.cameras, imgs):
        assert img.shape[:2] == (cam.height, cam.width)
        p_c = transform_points(inv_T(T_W_B @ cam.T_b_c_array), p_w[None])[0]
        uv, _ = cv2.projectPoints(p_c[None], np.zeros(3), np.zeros(3), cam.K, cam.dist_coeffs)
        uv = uv.ravel()
        # Same 0.25 px budget; distortion shrinks the blob by < 15 % here and its curvature
        # across a 7 px blob moves the centroid by < 0.05 px.
        assert np.linalg.norm(_centroid(img) - uv) < 0.25, (cam.name, _centroid(img), uv)
        # And the distortion is really on: the pinhole projection is > 2x the tolerance away.
        uv0, _ = cv2.projectPoints(p_c[None], np.zeros(3), np.zeros(3), cam.K, np.zeros(5))
        assert np.linalg.norm(uv0.ravel() - uv) > 0.5


def test_distort_false_renders_the_pinhole_model():
    rig = stereo_rig(dist=(-0.3, 0.09, 4e-4, -3e-4, 0.0))
    p_w = _marker_world(rig, (1.2, -0.9, 4.0))
    imgs = _render_marker(rig, p_w, distort=False)
    for cam, img in zip(rig.cameras, imgs):
        p_c = transform_points(inv_T(T_W_B @ cam.T_b_c_array), p_w[None])[0]
        uv, _ = cv2.projectPoints(p_c[None], np.zeros(3), np.zeros(3), cam.K, np.zeros(5))
        assert img.shape[:2] == (cam.height, cam.width)
        assert np.linalg.norm(_centroid(img) - uv.ravel()) < 0.25


# ----------------------------------------------------------------------------- equidistant (fisheye)
FISHEYE_K = (-0.01, 0.04, -0.04, 0.008)


def _fisheye_rig():
    """The render-test rig (fx != fy, off-centre principal point, tilted cameras) with equidistant lenses:
    320x240, fx = 200, fy = 185 px: the farthest image corner sees rays 67.5 deg off axis."""
    rig = stereo_rig(width=320, height=240, fx=200.0, fy=185.0)
    cams = tuple(dataclasses.replace(c, dist=FISHEYE_K, dist_model="equidistant") for c in rig.cameras)
    return dataclasses.replace(rig, cameras=cams)


def _fisheye_silhouette_centroid(p_c, r, cam, n=4096):
    """Area centroid [px] of the exact image of a sphere through cv2.fisheye: the silhouette cone's
    boundary rays (half-angle asin(r/|c|) about c) projected by cv2.fisheye.projectPoints give a polygon
    (n vertices, chord error ~ (2 pi / n)^2 of the radius: << 1e-3 px), whose centroid is the shoelace one."""
    c = p_c / np.linalg.norm(p_c)
    a = np.arcsin(r / np.linalg.norm(p_c))
    e1 = np.cross(c, [0.0, 0.0, 1.0] if abs(c[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(c, e1)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)[:, None]
    rays = np.cos(a) * c + np.sin(a) * (np.cos(t) * e1 + np.sin(t) * e2)
    x, y = cam.project(rays).T
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    A = cross.sum() / 2
    return np.array([((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()]) / (6 * A)


# Markers 4 m from cam0 along the rays of these cam0 pixels: the principal point, then ~37, ~42 and
# ~52 deg off axis in three quadrants (the ~10 px blobs stay >= 10 px inside both images).
FISHEYE_UV0 = [(183.3, 102.9), (290.0, 35.0), (60.0, 30.0), (45.0, 210.0)]


@pytest.mark.slow
@pytest.mark.parametrize("uv0", FISHEYE_UV0)
def test_marker_projects_with_fisheye(uv0):
    rig = _fisheye_rig()
    ray = np.append(rig.cameras[0].undistort_normalized(np.array([uv0]))[0], 1.0)
    p_w = _marker_world(rig, 4.0 * ray / np.linalg.norm(ray))
    imgs = _render_marker(rig, p_w)
    for cam, img in zip(rig.cameras, imgs):
        assert img.shape[:2] == (cam.height, cam.width)
        p_c = transform_points(inv_T(T_W_B @ cam.T_b_c_array), p_w[None])[0]
        uv, _ = cv2.fisheye.projectPoints(p_c.reshape(1, 1, 3), np.zeros((3, 1)), np.zeros((3, 1)), cam.K,
                                          np.array(FISHEYE_K))
        uv = uv.ravel()
        # The fisheye stretches the blob tangentially (theta / sin theta): its area centroid sits
        # off the projected sphere centre by a computed amount, < 0.15 px for these markers.
        sil = _fisheye_silhouette_centroid(p_c, RADIUS, cam)
        assert np.linalg.norm(sil - uv) < 0.15
        # 0.25 px: the radtan test's rasterisation budget (the canvas samples the fisheye at least 1:1,
        # and finer off axis), so the total budget against cv2.fisheye.projectPoints is 0.25 + 0.15 px.
        assert np.linalg.norm(_centroid(img) - sil) < 0.25, (cam.name, _centroid(img), sil, uv)
        assert np.linalg.norm(_centroid(img) - uv) < 0.4
        # The lens model is really on: a pinhole projection of the same point is far away (off axis).
        if np.linalg.norm(p_c[:2]) / p_c[2] > 0.3:
            uv0, _ = cv2.projectPoints(p_c[None], np.zeros(3), np.zeros(3), cam.K, np.zeros(5))
            assert np.linalg.norm(uv0.ravel() - uv) > 5.0
