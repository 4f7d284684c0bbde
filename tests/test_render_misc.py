"""Distortion maps, image noise, errors, benchmark plumbing."""
from __future__ import annotations

import numpy as np
import pytest

from test_render_support import RenderTestScene, stereo_rig
from rigs.model import Camera
from scenes.base import SceneConfig
from sim.app.bench_render import bench_render, route_poses
from sim.distortion import DistortionMap, reprojection_error_px, undistort_exact
from sim.errors import SimError
from rigs.errors import RecordError
from rigs.image_noise import add_image_noise
from sim.world import build_world

EUROC_CAM = Camera("cam0", 752, 480, 458.654, 457.296, 367.215, 248.375,
                   dist=(-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0))


def test_inverse_distortion_is_exact_over_the_whole_image():
    v, u = np.mgrid[0:480:7, 0:752:7].astype(np.float64)
    uv = np.stack([u.ravel(), v.ravel()], axis=1)
    xy = undistort_exact(uv, EUROC_CAM)
    # Requirement 1e-3 px; Newton converges to float64 round-off (~1e-12 px).
    assert reprojection_error_px(xy, uv, EUROC_CAM).max() < 1e-6


def test_canvas_covers_barrel_distortion_and_maps_are_consistent():
    m = DistortionMap(EUROC_CAM)
    c = m.canvas_camera
    # Barrel: the distorted frame's corners come from outside the pinhole 752x480 frame.
    assert c.width > 752 and c.height > 480 and (c.fx, c.fy) == (EUROC_CAM.fx, EUROC_CAM.fy)
    assert m.map_x.min() >= 1.0 and m.map_x.max() <= c.width - 2
    assert m.map_y.min() >= 1.0 and m.map_y.max() <= c.height - 2
    # Apply to a synthetic canvas whose value is its own column index: output = map_x (bilinear
    # on a linear ramp is exact up to cv2.remap's 1/32-px weight quantisation -> <= 1/64 px).
    ramp = np.tile(np.arange(c.width, dtype=np.float32), (c.height, 1))
    assert np.abs(m.apply(ramp) - m.map_x).max() <= 1 / 64 + 1e-4
    depth = np.full((c.height, c.width), 7.5, np.float32)
    assert m.apply_depth(depth).shape == (480, 752) and np.all(m.apply_depth(depth) == 7.5)
    with pytest.raises(SimError, match="canvas"):
        m.apply(np.zeros((480, 752), np.uint8))


def test_pinhole_map_is_identity():
    cam = Camera("c", 64, 48, 50.0, 55.0, 30.2, 20.7)
    m = DistortionMap(cam)
    img = np.random.default_rng(0).integers(0, 255, (m.canvas_camera.height, m.canvas_camera.width, 3),
                                            dtype=np.uint8)
    out = m.apply(img)
    assert out.shape == (48, 64, 3)
    np.testing.assert_array_equal(out, img[m.v0 * -1:m.v0 * -1 + 48, -m.u0:-m.u0 + 64])


def test_image_noise_statistics_and_determinism():
    img = np.full((200, 300), 128, np.uint8)
    a = add_image_noise(img, 3.0, np.random.default_rng(5))
    b = add_image_noise(img, 3.0, np.random.default_rng(5))
    assert a.dtype == np.uint8 and np.array_equal(a, b)
    d = a.astype(float) - 128
    # 60000 samples: sample std within 2 % of 3.0 (rounding adds 1/12 variance: sqrt(9+1/12)=3.014).
    assert abs(d.mean()) < 0.05 and abs(d.std() - np.sqrt(9 + 1 / 12)) < 0.06
    assert add_image_noise(np.full((10, 10), 254, np.uint8), 50.0, np.random.default_rng(1)).max() == 255
    assert np.array_equal(add_image_noise(img, 0.0, np.random.default_rng(1)), img)
    with pytest.raises(RecordError, match="sigma"):
        add_image_noise(img, -1.0, np.random.default_rng(1))
    with pytest.raises(RecordError, match="dtype"):
        add_image_noise(img, 1.0, np.random.default_rng(1), np.float16)
    # float64 sums (the Monte-Carlo re-noising) draw the same numbers: at most a rounding tie differs
    c = add_image_noise(img, 3.0, np.random.default_rng(5), np.float64)
    assert np.abs(c.astype(int) - a).max() <= 1 and np.mean(c != a) < 1e-3


def test_unknown_vehicle_kind_is_a_one_line_error():
    with pytest.raises(SimError, match=r"unknown kind 'bike'; valid: cart, rover"):
        build_world(RenderTestScene(), stereo_rig(), vehicle="bike")


def test_world_clip_planes_are_absolute():
    w = build_world(RenderTestScene(), stereo_rig())
    m = w.model
    assert m.vis.map.znear * m.stat.extent == pytest.approx(0.05)
    assert m.vis.map.zfar * m.stat.extent == pytest.approx(200.0)
    assert m.vis.quality.offsamples == 0
    assert all(not m.light_castshadow[i] for i in range(m.nlight))   # shadows=False -> no pass


def test_route_poses_follow_the_route():
    scene = RenderTestScene()             # straight route (0,0) -> (8,0)
    T = route_poses(scene, 4)
    np.testing.assert_allclose(T[:, 0, 3], [0, 2, 4, 6])
    np.testing.assert_allclose(T[:, :3, 0], np.tile([1.0, 0, 0], (4, 1)), atol=1e-12)


def test_bench_runs_on_a_small_rig():
    rig = stereo_rig()
    (res,) = bench_render(rig=rig, n_pairs=4, scenes=[RenderTestScene(SceneConfig(name="render_test"))])
    assert res.width == 160 and res.pairs_per_s > 0 and res.ms_per_pair == pytest.approx(1e3 / res.pairs_per_s)
    assert res.build_s > 0 and res.build_cpu_s > 0 and res.texture_mb >= 0


def test_shadows_on_keeps_only_the_brightest_caster():
    def dim_light(spec):
        spec.worldbody.add_light(name="dim", pos=[0, 0, 9], dir=[0, 0, -1], diffuse=[0.2] * 3, castshadow=True)
    w = build_world(RenderTestScene(SceneConfig(name="render_test", shadows=True)), stereo_rig(), extra=dim_light)
    m = w.model
    casts = {m.light(i).name: bool(m.light_castshadow[i]) for i in range(m.nlight)}
    assert casts == {"sun": True, "dim": False} and m.vis.quality.shadowsize > 0
