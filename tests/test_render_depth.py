"""Depth = z in the OpenCV camera frame, checked against exact ray-plane intersections."""
from __future__ import annotations

import cv2
import numpy as np

from test_render_support import RenderTestScene, stereo_rig, vehicle_pose
from sim.world import build_world
from sim.render import StereoRenderer


def _ray_plane_depth(cam, T_w_c, n_w, d_plane):
    """(H,W) exact optical-axis depth where pixel rays hit the plane n_w . p_w = d_plane.

    Ray of pixel (u, v): p_c(s) = s * K^-1 [u, v, 1] (z = s), p_w = R_w_c p_c + t_w_c.
    """
    v, u = np.mgrid[0:cam.height, 0:cam.width].astype(np.float64)
    ray_c = np.stack([(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, np.ones_like(u)], axis=-1)
    ray_w = ray_c @ T_w_c[:3, :3].T
    s = (d_plane - n_w @ T_w_c[:3, 3]) / (ray_w @ n_w)
    return np.where(s > 0, s, np.inf)


def _render(rig, T_w_b):
    world = build_world(RenderTestScene(wall_x=10.0), rig)
    with StereoRenderer(world, depth=True, segmentation=True) as r:
        frame = r.render(T_w_b)
    ids = {name: world.model.geom(name).id for name in ("wall", "ground")}
    return world, frame, ids


def test_depth_is_optical_axis_distance_to_wall_and_ground():
    rig = stereo_rig()
    T_w_b = vehicle_pose(x=0.0, yaw=0.1)
    world, frame, ids = _render(rig, T_w_b)
    for k, cam in enumerate(rig.cameras):
        T_w_c = T_w_b @ cam.T_b_c_array
        depth, seg = frame.depth[k], frame.seg[k][..., 0]
        assert depth.dtype == np.float32 and depth.shape == (cam.height, cam.width)
        for name, n_w, d_plane in (("wall", np.array([1.0, 0, 0]), 10.0),
                                   ("ground", np.array([0, 0, 1.0]), 0.0)):
            # Pixels whose 3x3 neighbourhood all see this plane (no silhouette pixels).
            mask = cv2.erode((seg == ids[name]).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
            assert mask.sum() > 500, name
            z_true = _ray_plane_depth(cam, T_w_c, n_w, d_plane)
            err = np.abs(depth[mask] - z_true[mask])
            # 1 mm at <= 11 m: float32 depth buffer with reversed Z keeps ~1e-6 relative
            # precision; along-the-ray distance would differ by up to 17 cm at the corners.
            assert err.max() < 1e-3, (name, cam.name, err.max())
            ray_len = z_true[mask] * np.sqrt(1 + ((np.argwhere(mask)[:, 1] - cam.cx) / cam.fx) ** 2)
            assert np.abs(depth[mask] - ray_len).max() > 0.05   # not the ray length


def test_depth_at_10m_wall_straight_ahead():
    """Camera axis-aligned 10 m in front of the wall: centre-pixel depth is 10 m - camera x."""
    rig = stereo_rig(tilt=False, dcx=0.0, dcy=0.0, width=81, height=61)
    world, frame, ids = _render(rig, vehicle_pose())
    cam = rig.cameras[0]
    # The principal point (40.5, 30.5) lies between pixels; the four around it see z = 10 - 0.05.
    z = frame.depth[0][30:32, 40:42]
    np.testing.assert_allclose(z, 10.0 - cam.T_b_c_array[0, 3], atol=1e-3)


def test_sky_is_infinite():
    """Without a wall the upper image sees only the skybox: depth inf there, finite on the ground."""
    rig = stereo_rig(tilt=False)
    world = build_world(RenderTestScene(wall_x=None, sky=True), rig)
    with StereoRenderer(world, depth=True) as r:
        frame = r.render(vehicle_pose())
    d, img = frame.depth[0], frame.images[0]
    cam = rig.cameras[0]
    horizon_v = int(cam.cy)                        # camera level: the horizon is at v = cy
    assert np.isinf(d[:horizon_v - 2]).all() and img[:horizon_v - 2].mean() > 50   # sky drawn
    assert np.isfinite(d[horizon_v + 5:]).all()     # ground (60 m half-size plane) below


def test_distorted_depth_is_nearest_canvas_sample():
    """With lens distortion, depth pixel (u, v) is the canvas depth at the nearest canvas pixel
    to its exact undistorted source location: check against ray geometry through that pixel."""
    rig = stereo_rig(dist=(-0.3, 0.09, 4e-4, -3e-4, 0.0))
    T_w_b = vehicle_pose(yaw=0.1)
    world, frame, ids = _render(rig, T_w_b)
    for k, cam in enumerate(rig.cameras):
        dmap, canvas = world.distortion_maps[k], world.render_rig.cameras[k]
        assert frame.depth[k].shape == (cam.height, cam.width) == frame.seg[k].shape[:2]
        mask = cv2.erode((frame.seg[k][..., 0] == ids["wall"]).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        z_canvas = _ray_plane_depth(canvas, T_w_b @ canvas.T_b_c_array, np.array([1.0, 0, 0]), 10.0)
        # cv2.remap INTER_NEAREST rounds the float32 map to the nearest integer canvas pixel.
        ui = np.rint(dmap.map_x).astype(int)
        vi = np.rint(dmap.map_y).astype(int)
        z_pred = z_canvas[vi, ui]
        assert mask.sum() > 500
        assert np.abs(frame.depth[k][mask] - z_pred[mask]).max() < 1e-3
