"""EuRoC writer -> reader round trips, determinism, sensor.yaml extrinsics, depth/segmentation."""
from __future__ import annotations

import numpy as np
import pytest

from sim.writers import EurocWriter
from test_dataset_synth import Synth, folder_hashes
from vo.dataset import open_dataset
from vo.dataset.interp import interpolate_poses
from rigs.geometry import inv_T


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    s = Synth()
    out = tmp_path_factory.mktemp("euroc") / "seq"
    s.write(EurocWriter(out, s.rig, s.metadata, depth=True, segmentation=True), with_depth=True, with_seg=True)
    return s, out


def test_layout_headers_and_no_marker(written):
    s, out = written
    assert not (out / "INCOMPLETE").exists()
    for rel in ("mav0/cam0/data.csv", "mav0/cam1/sensor.yaml", "mav0/imu0/sensor.yaml", "rig.yaml",
                "mav0/state_groundtruth_estimate0/sensor.yaml", "groundtruth_tum.txt", "gcps.csv", "metadata.yaml"):
        assert (out / rel).is_file(), rel
    assert (out / "mav0/cam0/data.csv").read_text().splitlines()[0] == "#timestamp [ns],filename"
    assert (out / "mav0/imu0/data.csv").read_text().startswith("#timestamp [ns],w_RS_S_x [rad s^-1],")
    assert (out / f"mav0/cam1/data/{s.t_frames[2]}.png").is_file()


def test_images_imu_gt_rig_gcps_round_trip(written):
    s, out = written
    ds = open_dataset(out)
    assert ds.kind == "euroc" and len(ds) == 5 and ds.warnings == []
    assert ds.frame_times_ns.dtype == np.int64 and np.array_equal(ds.frame_times_ns, s.t_frames)
    for f, imgs in zip(ds.frames(), s.images):
        assert np.array_equal(f.left, imgs[0]) and np.array_equal(f.right, imgs[1])   # PNG is lossless
    # repr() floats round-trip float64 exactly, so the IMU comes back bit-identical.
    assert np.array_equal(ds.imu.t_ns, s.t_imu)
    assert np.array_equal(ds.imu.gyro, s.gyro) and np.array_equal(ds.imu.accel, s.accel)
    gt = ds.groundtruth
    assert gt.frame == "i" and np.array_equal(gt.t_ns, s.t_imu)
    # quaternion <-> matrix round trip costs a few ulps: 1e-12 is ~1e4 ulp of 1.0.
    assert np.allclose(gt.T, s.T_w_i, atol=1e-12)
    assert ds.rig == s.rig                    # exact: rig.yaml floats are repr-exact
    assert [g.name for g in ds.gcps] == ["G1", "G2"]
    for a, b in zip(ds.gcps, s.gcps):
        assert a.t_ns == b.t_ns and np.array_equal(a.ground_w, b.ground_w) and np.array_equal(a.p_w_c0, b.p_w_c0)
    assert ds.metadata["status"] == "complete" and ds.metadata["n_frames"] == 5 and ds.metadata["n_imu"] == 50
    assert ds.metadata["scene"] == s.metadata["scene"]


def test_groundtruth_cam0_tum_and_interpolated_agree(written):
    s, out = written
    ds = open_dataset(out)
    tum = ds.groundtruth_cam0()
    # groundtruth_tum.txt writes %.9f: 1e-8 covers rounding of positions and quaternions.
    assert tum.frame == "c0" and np.array_equal(tum.t_ns, s.t_frames)
    assert np.allclose(tum.T, s.T_w_c0, atol=1e-8)
    # The real-EuRoC path (gt of i interpolated at frame times, composed with T_i_c0) gives the same poses:
    # frame times coincide with gt samples, so interpolation is exact up to float rounding.
    T_i_c0 = inv_T(ds.rig.imu.T_b_i_array) @ ds.rig.cameras[0].T_b_c_array
    interp, keep = interpolate_poses(ds.groundtruth, ds.frame_times_ns)
    assert keep.all() and np.allclose(interp.T @ T_i_c0, s.T_w_c0, atol=1e-9)


def test_sensor_yaml_T_BS_is_T_i_c(written):
    from rigs.calib_io import read_euroc_camera_yaml, read_euroc_imu_yaml
    s, out = written
    for k in (0, 1):
        cam, rate = read_euroc_camera_yaml(out / f"mav0/cam{k}/sensor.yaml", f"cam{k}")
        expected = inv_T(s.rig.imu.T_b_i_array) @ s.rig.cameras[k].T_b_c_array
        assert np.allclose(cam.T_b_c_array, expected, atol=1e-12) and rate == 20.0
    assert np.allclose(read_euroc_imu_yaml(out / "mav0/imu0/sensor.yaml").T_b_i_array, np.eye(4))


def test_depth_and_segmentation_round_trip(written):
    s, out = written
    ds = open_dataset(out)
    assert ds.depth(3).dtype == np.float32 and np.array_equal(ds.depth(3), s.depth[3])
    with pytest.raises(Exception, match="depth was not recorded"):
        ds.depth(3, cam=1)
    ids, dyn = ds.segmentation(2)
    assert np.array_equal(ids, s.seg[2][..., 0]) and np.array_equal(dyn, s.seg[2][..., 1] != 0)


def test_rgb_images_read_back_as_gray(tmp_path):
    import cv2
    s = Synth(rgb=True, n_frames=2)
    s.write(EurocWriter(tmp_path / "rgb", s.rig, s.metadata))
    f = open_dataset(tmp_path / "rgb").frame(1)
    expected = cv2.cvtColor(s.images[1][0], cv2.COLOR_RGB2GRAY)    # same weights both ways: exact
    assert f.left.dtype == np.uint8 and np.array_equal(f.left, expected)


def test_same_inputs_give_byte_identical_folders(tmp_path):
    hashes = []
    for name in ("a", "b"):
        s = Synth(seed=3)
        s.write(EurocWriter(tmp_path / name, s.rig, s.metadata, depth=True), with_depth=True)
        hashes.append(folder_hashes(tmp_path / name))
    assert hashes[0] == hashes[1] and "metadata.yaml" in hashes[0] and len(hashes[0]) > 20


def test_imu_object_form_tum_helper_and_mav0_path(tmp_path, written):
    from types import SimpleNamespace
    from sim.writers import DatasetWriters, write_tum_groundtruth
    from sim.errors import SimError
    from rigs.trajfile import read_tum
    s, out = written
    assert open_dataset(out / "mav0").path == out            # opening mav0 itself finds our extras
    w = EurocWriter(tmp_path / "o", s.rig, s.metadata)
    w.add_imu(SimpleNamespace(t_ns=s.t_imu, gyro=s.gyro, accel=s.accel))   # ImuSamples-like object
    w.finalize()
    assert np.array_equal(open_dataset(tmp_path / "o").imu.accel, s.accel)
    traj = open_dataset(out).groundtruth
    write_tum_groundtruth(tmp_path / "gt.txt", traj)
    assert np.allclose(read_tum(tmp_path / "gt.txt").T, traj.T, atol=1e-8)   # %.9f text
    with pytest.raises(SimError, match="valid: euroc, kitti, both"):
        DatasetWriters(tmp_path / "z", s.rig, s.metadata, fmt="tum")


def _rig_with_k3(rig, k3=0.0507):
    import dataclasses
    cams = tuple(dataclasses.replace(c, dist=(0.0176, -0.0356, -0.0006, -0.0005, k3 * (1 + k)))
                 for k, c in enumerate(rig.cameras))
    return dataclasses.replace(rig, cameras=cams)


def test_sensor_yaml_and_kalibr_have_four_coefficients_and_say_k3_is_dropped(tmp_path):
    # As real EuRoC and Kalibr: 4 radtan coefficients in sensor.yaml and camchain-imucam.yaml. A rig with
    # k3 != 0 cannot be expressed there: the Kalibr files say so in a comment, rig.yaml stays exact.
    from rigs.calib_io import read_euroc_camera_yaml
    from rigs.kalibr_io import read_kalibr
    from rigs.config_io import read_yaml_file
    s = Synth(n_frames=2)
    rig = _rig_with_k3(s.rig)
    s.write(EurocWriter(tmp_path / "k3", rig, s.metadata))
    chain = read_yaml_file(tmp_path / "k3/mav0/camchain-imucam.yaml")
    for k in (0, 1):
        coeffs = read_yaml_file(tmp_path / f"k3/mav0/cam{k}/sensor.yaml")["distortion_coefficients"]
        assert coeffs == list(rig.cameras[k].dist[:4])
        assert read_euroc_camera_yaml(tmp_path / f"k3/mav0/cam{k}/sensor.yaml")[0].dist[4] == 0.0
        assert chain[f"cam{k}"]["distortion_coeffs"] == list(rig.cameras[k].dist[:4])
    sensor = (tmp_path / "k3/mav0/cam0/sensor.yaml").read_text()    # the k3 said inside sensor.yaml itself
    assert f"# NOT EXACT: EuRoC's radial-tangential has 4 coefficients; cam0: k3 = {rig.cameras[0].dist[4]!r} " \
           f"dropped (up to " in sensor and "rig.yaml at the dataset root holds the exact calibration" in sensor
    assert "NOT EXACT" not in (tmp_path / "k3/mav0/imu0/sensor.yaml").read_text()
    text = (tmp_path / "k3/mav0/camchain-imucam.yaml").read_text()
    assert "# NOT EXACT" in text and f"cam1 (cam1): k3 = {rig.cameras[1].dist[4]!r} dropped" in text
    assert "sensor.yaml and the Kalibr mav0/camchain-imucam.yaml list 4 radtan coefficients and omit k3" in \
        read_yaml_file(tmp_path / "k3/metadata.yaml")["calibration"]
    back = read_kalibr(tmp_path / "k3/mav0/camchain-imucam.yaml")
    assert [c.dist for c in back.cameras] == [tuple(c.dist[:4]) + (0.0,) for c in rig.cameras]
    s.write(EurocWriter(tmp_path / "no_k3", s.rig, s.metadata))  # k3 = 0: every calibration file is exact
    assert "NOT EXACT" not in (tmp_path / "no_k3/mav0/camchain-imucam.yaml").read_text()
    assert "NOT EXACT" not in (tmp_path / "no_k3/mav0/cam0/sensor.yaml").read_text()
    assert "are exact" in read_yaml_file(tmp_path / "no_k3/metadata.yaml")["calibration"]


def test_real_layout_with_five_coefficient_camchain_takes_exact_distortion(tmp_path):
    # A folder without rig.yaml read as real EuRoC: a mav0/camchain.yaml with a fifth coefficient
    # (a Kalibr-like file some tools write) gives the exact distortion.
    import yaml
    from rigs.kalibr_io import kalibr_camchain_dict
    s = Synth(n_frames=2)
    rig = _rig_with_k3(s.rig)
    s.write(EurocWriter(tmp_path / "k3", rig, s.metadata))
    d = kalibr_camchain_dict(rig)
    for k in (0, 1):
        d[f"cam{k}"]["distortion_coeffs"] = list(rig.cameras[k].dist)
    (tmp_path / "k3/mav0/camchain.yaml").write_text(yaml.safe_dump(d))
    (tmp_path / "k3/rig.yaml").unlink()
    (tmp_path / "k3/metadata.yaml").unlink()                     # now read as a real EuRoC folder
    ds = open_dataset(tmp_path / "k3")
    assert [c.dist for c in ds.rig.cameras] == [c.dist for c in rig.cameras]


@pytest.mark.parametrize("fmt, per_m", [("png16-mm", 1000.0), ("png16", 1000.0), ("tum", 5000.0)])
def test_depth_png_scale_and_sky(tmp_path, fmt, per_m):
    # uint16 PNG depth: png16-mm (and its alias png16) in millimetres, tum at TUM RGB-D's 5000 per metre;
    # 0 = sky or beyond 65535 counts; read back as metres, inf there, within half a count of rounding.
    import cv2
    s = Synth(n_frames=2)
    depth = s.depth[1].copy()
    depth[0, :5] = np.inf
    depth[1, 0] = 70.0                                            # beyond the 16-bit range of both scales
    depth[1, 1] = 12.0                                            # 60000 counts at 5000/m: in range for tum
    s.depth[1] = depth
    s.write(EurocWriter(tmp_path / "p", s.rig, s.metadata, depth=True, depth_format=fmt), with_depth=True)
    raw = cv2.imread(str(tmp_path / f"p/mav0/cam0/depth/{s.t_frames[1]}.png"), cv2.IMREAD_UNCHANGED)
    assert raw.dtype == np.uint16 and raw[0, 0] == 0 and raw[1, 0] == 0
    assert raw[1, 1] == round(12.0 * per_m)                       # a TUM loader (png / 5000) reads 12 m
    got = open_dataset(tmp_path / "p").depth(1)
    finite = np.isfinite(depth) & (depth * per_m <= 65535)
    assert np.all(np.isinf(got[~finite]))
    assert np.max(np.abs(got[finite] - depth[finite])) <= 0.5 / per_m + 1e-6    # half a count of rounding
    with pytest.raises(Exception, match="depth_format: unknown"):
        EurocWriter(tmp_path / "q", s.rig, s.metadata, depth=True, depth_format="exr")


def test_no_gcp_file_without_gcps(tmp_path):
    # An empty gcps.csv is rejected by `eval --gcps`, so none is written; metadata says why.
    from rigs.config_io import read_yaml_file
    s = Synth(n_frames=2)
    w = EurocWriter(tmp_path / "g", s.rig, s.metadata)
    s.write(w, finalize=False)
    w.finalize()
    assert not (tmp_path / "g/gcps.csv").exists()
    assert "gcps.csv not written" in read_yaml_file(tmp_path / "g/metadata.yaml")["gcps"]
    assert open_dataset(tmp_path / "g").gcps == []
