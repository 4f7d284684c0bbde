"""Kalibr, EuRoC sensor.yaml and KITTI calib.txt round trips, and real-file fixtures."""
from pathlib import Path

import numpy as np
import pytest
import yaml

from rigs import RigError
from rigs.calib_io import (read_euroc_camera_yaml, read_euroc_imu_yaml, read_kitti_calib, write_euroc_camera_yaml,
                            write_euroc_imu_yaml, write_kitti_calib)
from rigs.kalibr_io import kalibr_camchain_dict, read_kalibr, read_kalibr_timeshift, write_kalibr
from rigs.presets import get_rig
from rigs.rectify import stereo_rectify
from rigs.geometry.se3 import inv_T

# Real EuRoC MAV file mav0/cam0/sensor.yaml (OpenCV '%YAML:1.0' header, comments, 4 coefficients).
EUROC_CAM0_SENSOR_YAML = """%YAML:1.0
# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
"""

# Real EuRoC MAV file mav0/imu0/sensor.yaml.
EUROC_IMU0_SENSOR_YAML = (Path(__file__).parent / "fixtures" / "euroc_imu0_sensor.yaml").read_text()


def test_real_euroc_sensor_yaml_parses(tmp_path):
    (tmp_path / "cam.yaml").write_text(EUROC_CAM0_SENSOR_YAML)
    cam, rate = read_euroc_camera_yaml(tmp_path / "cam.yaml", "cam0")
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (458.654, 457.296, 367.215, 248.375)
    assert cam.dist == (-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0)
    assert (cam.width, cam.height, rate) == (752, 480, 20.0)
    # T_BS printed with ~12 digits: re-orthonormalised, so entries move by < 1e-6.
    assert cam.T_b_c_array[0, 3] == -0.0216401454975
    assert abs(cam.T_b_c_array[1, 0] - 0.999557249008) < 1e-6
    (tmp_path / "imu.yaml").write_text(EUROC_IMU0_SENSOR_YAML)
    imu = read_euroc_imu_yaml(tmp_path / "imu.yaml")
    assert (imu.gyro_noise_density, imu.gyro_random_walk, imu.accel_noise_density, imu.accel_random_walk,
            imu.rate_hz) == (1.6968e-04, 1.9393e-05, 2.0e-3, 3.0e-3, 200.0)


@pytest.mark.parametrize("name", ["cart27", "stereo27", "fisheye150"])
def test_euroc_round_trip(tmp_path, name):
    rig = get_rig(name)
    T_i_b = inv_T(rig.imu.T_b_i_array)
    for k, cam in enumerate(rig.cameras):
        path = tmp_path / f"cam{k}" / "sensor.yaml"
        write_euroc_camera_yaml(path, cam, T_i_b @ cam.T_b_c_array, rig.camera_rate_hz)
        assert path.read_text().startswith("%YAML:1.0\n")
        back, rate = read_euroc_camera_yaml(path, cam.name)
        assert rate == rig.camera_rate_hz
        assert (back.width, back.height, back.fx, back.fy, back.cx, back.cy, back.dist, back.dist_model) == \
            (cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, cam.dist, cam.dist_model)
        want = "equidistant" if cam.is_fisheye else "radial-tangential"
        assert f"distortion_model: {want}\n" in path.read_text()
        np.testing.assert_allclose(back.T_b_c_array, T_i_b @ cam.T_b_c_array, atol=1e-12)
    write_euroc_imu_yaml(tmp_path / "imu0" / "sensor.yaml", rig.imu, np.eye(4))
    imu = read_euroc_imu_yaml(tmp_path / "imu0" / "sensor.yaml")
    assert (imu.gyro_noise_density, imu.accel_random_walk, imu.rate_hz) == \
        (rig.imu.gyro_noise_density, rig.imu.accel_random_walk, rig.imu.rate_hz)


def test_integral_rates_are_written_as_integers(tmp_path):
    # Real EuRoC writes `rate_hz: 20`; ORB-SLAM3 aborts on a non-integer camera rate copied from it.
    rig = get_rig("cart27")
    write_euroc_camera_yaml(tmp_path / "c.yaml", rig.cameras[0], np.eye(4), 10.0)
    write_euroc_camera_yaml(tmp_path / "d.yaml", rig.cameras[0], np.eye(4), 12.5)
    write_euroc_imu_yaml(tmp_path / "i.yaml", rig.imu, np.eye(4))
    assert "\nrate_hz: 10\n" in (tmp_path / "c.yaml").read_text()
    assert "\nrate_hz: 12.5\n" in (tmp_path / "d.yaml").read_text()
    assert "\nrate_hz: 200\n" in (tmp_path / "i.yaml").read_text()
    assert read_euroc_camera_yaml(tmp_path / "c.yaml")[1] == 10.0


def test_k3_corner_error_matches_an_independent_undistortion():
    # cart27 without k3: the corner pixel, undistorted exactly (scipy root of the full model) and
    # re-distorted with k1 k2 p1 p2 alone, moves by the figure the sensor.yaml comment prints (~8 px).
    from scipy.optimize import fsolve
    from rigs.calib_io import k3_corner_error_px
    cam = get_rig("cart27").cameras[0]

    def distort(xy, d):
        k1, k2, p1, p2, k3 = d
        x, y = xy
        r2 = x * x + y * y
        rad = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
        return np.array([x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                         y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y])

    worst = 0.0
    for u, v in ((0, 0), (cam.width - 1, 0), (0, cam.height - 1), (cam.width - 1, cam.height - 1)):
        m = np.array([(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy])
        xy = fsolve(lambda q: distort(q, cam.dist) - m, m, xtol=1e-14)
        q = distort(xy, tuple(cam.dist[:4]) + (0.0,))
        worst = max(worst, float(np.hypot(cam.fx * q[0] + cam.cx - u, cam.fy * q[1] + cam.cy - v)))
    assert 7.0 < worst < 9.0
    assert k3_corner_error_px(cam) == pytest.approx(worst, abs=1e-3)


def test_euroc_k3_written_only_if_nonzero(tmp_path):
    c0 = get_rig("cart27").cameras[0]
    write_euroc_camera_yaml(tmp_path / "a.yaml", c0, np.eye(4), 10)
    assert "distortion_coefficients: [0.0176, -0.0356, -0.0006, -0.0005, 0.0507]" in (tmp_path / "a.yaml").read_text()
    c = get_rig("stereo27").cameras[0]
    write_euroc_camera_yaml(tmp_path / "b.yaml", c, np.eye(4), 10)
    assert "distortion_coefficients: [0.0, 0.0, 0.0, 0.0]\n" in (tmp_path / "b.yaml").read_text()


def _assert_same_rig(a, b, tol=1e-12):
    """Every number of two rigs within ``tol`` (names of rig, cameras, IMU and the mount aside)."""
    assert len(a.cameras) == len(b.cameras)
    for ca, cb in zip(a.cameras, b.cameras):
        assert (ca.width, ca.height, ca.dist_model) == (cb.width, cb.height, cb.dist_model)
        np.testing.assert_allclose([cb.fx, cb.fy, cb.cx, cb.cy, *cb.dist], [ca.fx, ca.fy, ca.cx, ca.cy, *ca.dist],
                                   rtol=0, atol=tol)
        np.testing.assert_allclose(cb.T_b_c_array, ca.T_b_c_array, rtol=0, atol=tol)
    ia, ib = a.imu, b.imu
    assert (ib.rate_hz, ib.accel_noise_density, ib.gyro_noise_density, ib.accel_random_walk, ib.gyro_random_walk) == \
        (ia.rate_hz, ia.accel_noise_density, ia.gyro_noise_density, ia.accel_random_walk, ia.gyro_random_walk)
    np.testing.assert_allclose(ib.T_b_i_array, ia.T_b_i_array, rtol=0, atol=tol)
    assert b.camera_rate_hz == a.camera_rate_hz


def _without_k3(rig):
    import dataclasses
    return dataclasses.replace(rig, cameras=tuple(c if c.is_fisheye else dataclasses.replace(c, dist=tuple(c.dist[:4]) + (0.0,))
                                                  for c in rig.cameras))


@pytest.mark.parametrize("name", ["stereo27", "yutu-navcam", "kitti-like", "paper002", "cart27", "fisheye150"])
def test_kalibr_round_trip(tmp_path, name):
    # rig -> camchain-imucam.yaml + imu.yaml -> rig: the same numbers to 1e-12, the body frame included
    # (imu.yaml's T_i_b); cart27's k3 cannot be expressed in Kalibr's radtan and comes back 0.
    rig = get_rig(name)
    write_kalibr(rig, tmp_path / "camchain-imucam.yaml", tmp_path / "imu.yaml", timeshift_s=-0.0025)
    back = read_kalibr(tmp_path / "camchain-imucam.yaml", tmp_path / "imu.yaml", camera_rate_hz=rig.camera_rate_hz)
    _assert_same_rig(_without_k3(rig), back)
    assert read_kalibr_timeshift(tmp_path / "camchain-imucam.yaml") == -0.0025
    # Kalibr's own conventions: T_cam_imu = T_c_i, T_cn_cnm1 of cam1 = T_c1_c0, 4 coefficients, integral rate
    d = yaml.safe_load((tmp_path / "camchain-imucam.yaml").read_text())
    T_i_c0 = inv_T(rig.imu.T_b_i_array) @ rig.cameras[0].T_b_c_array
    np.testing.assert_allclose(d["cam0"]["T_cam_imu"], inv_T(T_i_c0), atol=1e-12)
    np.testing.assert_allclose(d["cam1"]["T_cn_cnm1"], inv_T(rig.T_c0_c1), atol=1e-12)
    # fisheye150 is Kalibr's pinhole-equi: camera_model pinhole, distortion_model equidistant, k1..k4 exact.
    assert d["cam0"]["camera_model"] == "pinhole"
    assert d["cam0"]["distortion_model"] == ("equidistant" if name == "fisheye150" else "radtan")
    assert len(d["cam0"]["distortion_coeffs"]) == 4
    assert d["cam0"]["resolution"] == [rig.cameras[0].width, rig.cameras[0].height]
    assert d["cam1"]["timeshift_cam_imu"] == -0.0025 and d["cam1"]["rostopic"] == "/cam1/image_raw"
    imu = yaml.safe_load((tmp_path / "imu.yaml").read_text())["imu0"]
    assert imu["update_rate"] == 200 and isinstance(imu["update_rate"], int) and imu["rostopic"] == "/imu0"
    assert ("NOT EXACT" in (tmp_path / "camchain-imucam.yaml").read_text()) == (name == "cart27")


def test_kalibr_rig_through_get_rig_and_cli_config(tmp_path):
    # --rig camchain-imucam.yaml [--imu imu.yaml]: get_rig recognises the camchain; the config takes
    # {kalibr: camchain, imu: imu.yaml}; camera_rate_hz comes with --set (Kalibr has no field for it).
    from sim.generate_config import GenerateConfig
    rig = get_rig("stereo27")
    write_kalibr(rig, tmp_path / "camchain-imucam.yaml", tmp_path / "imu.yaml")
    alone = get_rig(str(tmp_path / "camchain-imucam.yaml"))
    np.testing.assert_allclose(alone.T_c0_c1, rig.T_c0_c1, atol=1e-12)
    assert alone.imu.name == "ideal"
    cfg = GenerateConfig().with_value("rig", {"kalibr": str(tmp_path / "camchain-imucam.yaml"),
                                              "imu": str(tmp_path / "imu.yaml")})
    cfg = cfg.with_overrides(["camera_rate_hz=20"])
    _assert_same_rig(rig, cfg.rig)


def test_kalibr_reads_four_coefficients_and_chains_T_cn_cnm1(tmp_path):
    rig = get_rig("stereo27")
    d = kalibr_camchain_dict(rig)
    del d["cam1"]["T_cam_imu"]             # cam1 pose must come from cam0 and T_cn_cnm1
    assert len(d["cam0"]["distortion_coeffs"]) == 4
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(d))
    back = read_kalibr(tmp_path / "c.yaml")
    np.testing.assert_allclose(back.T_c0_c1, rig.T_c0_c1, atol=1e-12)
    assert back.imu.name == "ideal"


def test_kalibr_bad_model_names_field(tmp_path):
    d = kalibr_camchain_dict(get_rig("stereo27"))
    d["cam1"]["distortion_model"] = "fov"
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(d))
    with pytest.raises(RigError) as e:
        read_kalibr(tmp_path / "c.yaml")
    assert str(e.value) == (f"{tmp_path / 'c.yaml'}: cam1.distortion_model: only 'radtan' and 'equidistant' are "
                            f"supported, got 'fov'")
    d["cam1"]["distortion_model"] = "equidistant"           # equidistant has exactly 4 coefficients
    d["cam1"]["distortion_coeffs"] = [0.1, 0.0, 0.0, 0.0, 0.0]
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(d))
    with pytest.raises(RigError, match=r"cam1\.distortion_coeffs"):
        read_kalibr(tmp_path / "c.yaml")


@pytest.mark.parametrize("name, tol", [("stereo27", 1e-9), ("cart27", 1e-6)])
def test_kitti_calib_from_rectification_gives_baseline(tmp_path, name, tol):
    rig = get_rig(name)
    rect = stereo_rectify(rig)
    write_kitti_calib(tmp_path / "calib.txt", rect.P0, rect.P1, Tr=np.eye(4)[:3])
    lines = (tmp_path / "calib.txt").read_text().splitlines()
    assert [ln.split(":")[0] for ln in lines] == ["P0", "P1", "P2", "P3", "Tr"]
    back = read_kitti_calib(tmp_path / "calib.txt", width=rig.cameras[0].width, height=rig.cameras[0].height)
    assert back.baseline == pytest.approx(rig.baseline, abs=tol)
    np.testing.assert_allclose(back.cameras[0].K, rect.K_rect, atol=1e-9)
    np.testing.assert_allclose(back.cameras[0].T_b_c_array, np.eye(4))
    assert back.camera_rate_hz == 10.0


def test_kitti_real_layout_parses(tmp_path):
    # KITTI odometry sequence 00 calib.txt (P0, P1 only shown in full; P2/P3/Tr as in the file).
    text = ("P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 0.000000000000e+00 "
            "7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
            "1.000000000000e+00 0.000000000000e+00\n"
            "P1: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 -3.861448000000e+02 0.000000000000e+00 "
            "7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
            "1.000000000000e+00 0.000000000000e+00\n")
    (tmp_path / "calib.txt").write_text(text)
    rig = read_kitti_calib(tmp_path / "calib.txt")
    assert rig.baseline == pytest.approx(386.1448 / 718.856, abs=1e-12)     # 0.537 m
    assert (rig.cameras[0].width, rig.cameras[0].height, rig.cameras[1].cx) == (1241, 376, 607.1928)


def test_kitti_bad_line_names_file_and_line(tmp_path):
    (tmp_path / "calib.txt").write_text("P0: 1 2 3\n")
    with pytest.raises(RigError) as e:
        read_kitti_calib(tmp_path / "calib.txt")
    assert str(e.value) == f"{tmp_path / 'calib.txt'}: line 1 (P0): expected 12 finite numbers, got 3"


def test_euroc_wrong_sensor_type(tmp_path):
    (tmp_path / "s.yaml").write_text(EUROC_IMU0_SENSOR_YAML)
    with pytest.raises(RigError) as e:
        read_euroc_camera_yaml(tmp_path / "s.yaml", "cam0")
    assert "\n" not in str(e.value) and "s.yaml: " in str(e.value)


def _sensor_with_T(text, rows):
    data = ", ".join(repr(float(x)) for x in np.asarray(rows, dtype=float).reshape(16))
    start, end = text.index("  data: ["), text.index("]", text.index("  data: ["))
    return text[:start] + f"  data: [{data}" + text[end:]


def test_euroc_T_BS_printed_with_few_digits_is_reorthonormalised(tmp_path):
    T = np.array([[0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975],
                  [0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768],
                  [-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949],
                  [0, 0, 0, 1.0]])
    (tmp_path / "s.yaml").write_text(_sensor_with_T(EUROC_CAM0_SENSOR_YAML, np.round(T, 5)))
    cam, _ = read_euroc_camera_yaml(tmp_path / "s.yaml")
    R = cam.T_b_c_array[:3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(R, T[:3, :3], atol=1e-5)     # rounding to 5 decimals moves entries <= 5e-6
    T_bad = T.copy()
    T_bad[0, 0] = 0.5
    (tmp_path / "s.yaml").write_text(_sensor_with_T(EUROC_CAM0_SENSOR_YAML, T_bad))
    with pytest.raises(RigError) as e:
        read_euroc_camera_yaml(tmp_path / "s.yaml")
    assert str(e.value).startswith(f"{tmp_path / 's.yaml'}: T_BS: not a rigid transform")
