"""Equidistant (Kannala-Brandt) camera model: projection, YAML round trip, overrides, canvas limits."""
from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from rigs.errors import RigError
from rigs.overrides import apply_overrides
from rigs.presets import get_rig, rig_names
from rigs.rig_yaml import load_rig, save_rig
from rigs.model import Camera
from sim.distortion import MAX_FISHEYE_THETA_DEG, DistortionMap, fisheye_needed_theta
from sim.errors import SimError

K4 = (-0.01, 0.04, -0.04, 0.008)


def _cam(**kw):
    base = dict(name="f", width=640, height=480, fx=315.0, fy=310.0, cx=321.0, cy=238.0, dist=K4,
                dist_model="equidistant")
    base.update(kw)
    return Camera(**base)


def test_projection_is_the_kannala_brandt_polynomial():
    cam = _cam()
    th = np.radians(np.linspace(1.0, 75.0, 40))
    phi = np.linspace(0.0, 2 * np.pi, 40)
    rays = np.stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th)], axis=1) * 3.0
    uv = cam.project(rays)
    # Independent evaluation of the model: theta_d = theta (1 + k1 th^2 + k2 th^4 + k3 th^6 + k4 th^8).
    td = th * (1 + sum(k * th ** (2 * i + 2) for i, k in enumerate(K4)))
    expect = np.stack([cam.fx * td * np.cos(phi) + cam.cx, cam.fy * td * np.sin(phi) + cam.cy], axis=1)
    np.testing.assert_allclose(uv, expect, atol=1e-9)
    # The inverse returns the ray direction (x/z, y/z) to float precision.
    xy = cam.undistort_normalized(uv)
    np.testing.assert_allclose(xy, rays[:, :2] / rays[:, 2:], rtol=1e-10, atol=1e-10)


def test_radtan_coefficients_are_refused_for_a_fisheye_camera():
    cam = _cam()
    with pytest.raises(RigError, match="equidistant"):
        cam.dist_coeffs
    with pytest.raises(RigError, match="4 finite equidistant coefficients"):
        _cam(dist=(0.1, 0, 0, 0, 0))
    with pytest.raises(RigError, match="dist_model"):
        _cam(dist_model="kb8")
    assert cam.has_distortion and _cam(dist=(0, 0, 0, 0)).has_distortion   # equidistant is never pinhole


def test_rig_yaml_round_trip(tmp_path):
    rig = get_rig("fisheye150")
    save_rig(rig, tmp_path / "r.yaml")
    back = load_rig(tmp_path / "r.yaml")
    assert back == rig and back.cameras[0].dist_model == "equidistant"
    # A radtan rig writes no dist_model key (files stay as before).
    save_rig(get_rig("stereo27"), tmp_path / "s.yaml")
    assert "dist_model" not in (tmp_path / "s.yaml").read_text()


def test_rig_yaml_bad_model_names_the_field(tmp_path):
    text = (tmp_path / "r.yaml")
    save_rig(get_rig("fisheye150"), text)
    text.write_text(text.read_text().replace("dist_model: equidistant", "dist_model: fov", 1))
    with pytest.raises(RigError, match=r"r\.yaml: cameras\[0\]\.dist_model: unknown 'fov'; valid: radtan, equidistant"):
        load_rig(text)


def test_overrides_index_fisheye_coefficients():
    rig = apply_overrides(get_rig("fisheye150"), ["cam0.k4=0.002"])
    assert rig.cameras[0].dist == K4[:3] + (0.002,)
    with pytest.raises(RigError, match="has no coefficient p1"):
        apply_overrides(get_rig("fisheye150"), ["cam0.p1=0.001"])


def test_preset_is_listed_and_sees_150_degrees():
    assert "fisheye150" in rig_names()
    rig = get_rig("fisheye150")
    assert all(c.is_fisheye for c in rig.cameras) and abs(rig.baseline - 0.12) < 1e-12
    theta = math.degrees(fisheye_needed_theta(rig.cameras[0]))
    assert 74.0 < theta < 76.0          # 150 deg diagonal field of view


def test_fisheye_canvas_is_exact_and_wide():
    cam = get_rig("fisheye150").cameras[0]
    m = DistortionMap(cam)
    c = m.canvas_camera
    # The corner rays (75 deg) need 2 f tan(75 deg) ~ 7.5 f across the diagonal of the pinhole canvas.
    diag = math.hypot(c.width, c.height)
    assert 2 * cam.fx * math.tan(math.radians(74.5)) < diag < 2 * cam.fx * math.tan(math.radians(76)) + 10
    # Every map entry re-projects (through cv2.fisheye.projectPoints) onto its own pixel.
    v, u = np.mgrid[0:cam.height:9, 0:cam.width:9]
    xs = (m.map_x[v, u] + m.u0 - cam.cx) / cam.fx
    ys = (m.map_y[v, u] + m.v0 - cam.cy) / cam.fy
    rays = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], axis=1)
    uv, _ = cv2.fisheye.projectPoints(rays.reshape(-1, 1, 3), np.zeros((3, 1)), np.zeros((3, 1)), cam.K,
                                      cam.fisheye_coeffs)
    err = np.linalg.norm(uv.reshape(-1, 2) - np.stack([u.ravel(), v.ravel()], axis=1), axis=1)
    # float32 maps: 1900 px * 2^-24 ~ 1e-4 px of storage round-off, magnified <= 1x (fisheye compresses).
    assert err.max() < 2e-3


def test_fields_of_view_beyond_the_pinhole_limit_are_refused():
    # f = 150 px on 640x480: corners at 400/150 rad = 153 deg off axis -- no pinhole image holds that.
    with pytest.raises(SimError, match=f"more than {MAX_FISHEYE_THETA_DEG:g} degrees off axis"):
        DistortionMap(_cam(fx=150.0, fy=150.0, dist=(0, 0, 0, 0)))
    # A folding polynomial (theta_d decreasing before 80 deg) is refused too.
    with pytest.raises(SimError, match="not increasing"):
        DistortionMap(_cam(dist=(-0.5, 0, 0, 0)))
