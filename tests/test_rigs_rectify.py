"""Stereo rectification: identity for an ideal pair; rows align and disparity = f B / Z otherwise."""
import numpy as np
import pytest

from rigs.presets import get_rig
from rigs.rectify import stereo_rectify
from rigs.geometry import inv_T, transform_points
from rigs.geometry.pinhole import project


def test_parallel_rig_rectification_is_identity():
    rig = get_rig("stereo27")
    r = stereo_rectify(rig)
    np.testing.assert_allclose(r.R0_rect, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(r.R1_rect, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(r.K_rect, rig.cameras[0].K, atol=1e-9)
    assert r.P1[0, 3] == pytest.approx(-458.0 * 0.27, abs=1e-9) and r.size == (752, 480)


def _project(cam, p_c):
    return project(p_c, cam.K, cam.dist_coeffs)


def test_cart27_rows_align_and_disparity_matches_depth():
    rig = get_rig("cart27")
    r = stereo_rectify(rig)
    rng = np.random.default_rng(7)
    # Points 3-30 m ahead of c0, inside the central field of view.
    z = rng.uniform(3, 30, 50)
    p_c0 = np.c_[rng.uniform(-0.3, 0.3, 50) * z, rng.uniform(-0.2, 0.2, 50) * z, z]
    p_c1 = transform_points(inv_T(rig.T_c0_c1), p_c0)
    # Rectified pixels: rotate each camera's points into its rectified frame, project with K_rect.
    uv = []
    for R, p in zip((r.R0_rect, r.R1_rect), (p_c0, p_c1)):
        q = (p @ R.T) @ r.K_rect.T
        uv.append(q[:, :2] / q[:, 2:])
    # Pure float64 geometry: agreement to 1e-9 px shows R_r1_c1 R_c1_c0 = R_r0_c0, baseline along x.
    np.testing.assert_allclose(uv[0][:, 1], uv[1][:, 1], atol=1e-9)
    z_r0 = (p_c0 @ r.R0_rect.T)[:, 2]
    np.testing.assert_allclose(uv[0][:, 0] - uv[1][:, 0], r.K_rect[0, 0] * rig.baseline / z_r0, atol=1e-9)


def test_maps_point_to_the_source_pixels():
    rig = get_rig("cart27")
    r = stereo_rectify(rig)
    maps = r.maps()
    K_inv = np.linalg.inv(r.K_rect)
    for cam, R, (mx, my) in zip(rig.cameras, (r.R0_rect, r.R1_rect), maps):
        assert mx.shape == (480, 720) and mx.dtype == np.float32
        u, v = np.meshgrid(np.arange(0, 720, 37), np.arange(0, 480, 29))
        rays_r = np.c_[u.ravel(), v.ravel(), np.ones(u.size)] @ K_inv.T
        expect = _project(cam, rays_r @ R)          # p_c = R_r_c^T p_r
        got = np.c_[mx[v.ravel(), u.ravel()], my[v.ravel(), u.ravel()]]
        # float32 maps of ~700 px values: resolution ~6e-5 px; 1e-3 px tolerance.
        np.testing.assert_allclose(got, expect, atol=1e-3)
        # alpha=0 crops to valid pixels: every map entry falls inside the source image.
        assert mx.min() >= -0.5 and mx.max() <= 719.5 and my.min() >= -0.5 and my.max() <= 479.5


def test_rectified_rig_is_parallel_with_same_baseline():
    rig = get_rig("cart27")
    rect_rig = stereo_rectify(rig).rectified_rig(rig)
    np.testing.assert_allclose(rect_rig.T_c0_c1[:3, :3], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(rect_rig.T_c0_c1[:3, 3], [rig.baseline, 0, 0], atol=1e-9)
    assert not rect_rig.cameras[1].has_distortion
