"""The equidistant (fisheye) lens model through every dataset format: EuRoC sensor.yaml + Kalibr camchain
(exact, 4 coefficients), ROS camera_info (``equidistant``, read back by the bag reader), and KITTI, whose
calib.txt has no distortion at all: its images are rectified through cv2.fisheye."""
from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
import yaml

from test_dataset_synth import Synth, make_rig
from test_rosbag_export import read_bag

from rigs.calib_io import read_kitti_calib
from rigs.kalibr_io import read_kalibr
from rigs.rectify import stereo_rectify
from sim.writers import EurocWriter, KittiWriter
from sim.app.rosbag_export import export_rosbag
from vo.dataset import open_dataset

K4 = (-0.01, 0.04, -0.04, 0.008)


def fisheye_synth(n_frames=3, parallel=True):
    """The synthetic dataset with its cameras made equidistant (64x48, f = 50 px: corners ~44 deg off axis);
    ``parallel=False``: cam1 turned by 0.01 and -0.02 rad (cam0 and its truth unchanged)."""
    s = Synth(n_frames=n_frames)
    cams = tuple(dataclasses.replace(c, dist=K4, dist_model="equidistant") for c in make_rig(parallel).cameras)
    s.rig = dataclasses.replace(s.rig, cameras=cams)
    return s


def test_euroc_files_and_reader_keep_the_equidistant_model(tmp_path):
    s = fisheye_synth()
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    mav0 = tmp_path / "ds" / "mav0"
    sensor = yaml.safe_load((mav0 / "cam1" / "sensor.yaml").read_text().split("\n", 1)[1])
    assert sensor["distortion_model"] == "equidistant" and sensor["distortion_coefficients"] == list(K4)
    chain = yaml.safe_load((mav0 / "camchain-imucam.yaml").read_text())
    assert chain["cam0"]["camera_model"] == "pinhole" and chain["cam0"]["distortion_model"] == "equidistant"
    assert "NOT EXACT" not in (mav0 / "camchain-imucam.yaml").read_text()
    back = read_kalibr(mav0 / "camchain-imucam.yaml", mav0 / "imu.yaml", camera_rate_hz=s.rig.camera_rate_hz)
    assert [(c.dist_model, c.dist) for c in back.cameras] == [("equidistant", K4)] * 2
    ds = open_dataset(tmp_path / "ds")
    assert [(c.dist_model, c.dist) for c in ds.rig.cameras] == [("equidistant", K4)] * 2


def test_ros_camera_info_is_equidistant_and_reads_back(tmp_path):
    s = fisheye_synth()
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    export_rosbag(tmp_path / "ds", tmp_path / "f.bag", kind="rosbag1")
    msgs, _ = read_bag(tmp_path / "f.bag")
    info = msgs["/cam0/camera_info"][0][1]
    # ROS (sensor_msgs/distortion_models.h): "equidistant", D = k1 k2 k3 k4 as cv2.fisheye.
    assert info.distortion_model == "equidistant" and list(info.D) == list(K4)
    ds = open_dataset(tmp_path / "f.bag")
    assert [(c.dist_model, c.dist) for c in ds.rig.cameras] == [("equidistant", K4)] * 2


def test_fisheye_rectification_maps_follow_cv2_fisheye():
    # KITTI's calib.txt holds rectified pinhole projections only, so a fisheye pair is written rectified:
    # the map at a point's rectified pixel must give that point's fisheye pixel (cv2.fisheye.projectPoints).
    s = fisheye_synth()
    rect = stereo_rectify(s.rig)
    rng = np.random.default_rng(3)
    p_c0 = np.column_stack([rng.uniform(-0.4, 0.4, 40), rng.uniform(-0.3, 0.3, 40), np.full(40, 2.0)])
    T_c1_c0 = np.linalg.inv(s.rig.T_c0_c1)
    for k, (mx, my) in enumerate(rect.maps()):
        cam = s.rig.cameras[k]
        p = p_c0 if k == 0 else p_c0 @ T_c1_c0[:3, :3].T + T_c1_c0[:3, 3]
        R, P = (rect.R0_rect, rect.P0) if k == 0 else (rect.R1_rect, rect.P1)
        q = (p @ R.T) @ P[:, :3].T
        uv_r = q[:, :2] / q[:, 2:]
        inside = (uv_r[:, 0] > 1) & (uv_r[:, 0] < cam.width - 2) & (uv_r[:, 1] > 1) & (uv_r[:, 1] < cam.height - 2)
        assert inside.sum() > 20
        src = np.column_stack([cv2.remap(m, uv_r[inside, 0].astype(np.float32)[None], uv_r[inside, 1].astype(
            np.float32)[None], cv2.INTER_LINEAR)[0] for m in (mx, my)])
        # Bilinear interpolation of the smooth map over one pixel (curvature ~1e-3 px/px^2 here) and the
        # 1/32 px weights of cv2.remap: < 0.05 px.
        assert np.abs(src - cam.project(p[inside])).max() < 0.05
    # Both rectified rows agree (epipolar lines horizontal) and the baseline is the rig's.
    assert abs(rect.baseline - s.rig.baseline) < 1e-9


def test_kitti_writer_rectifies_a_fisheye_pair(tmp_path):
    s = fisheye_synth()
    s.write(KittiWriter(tmp_path / "k", s.rig, s.metadata))
    back = read_kitti_calib(tmp_path / "k" / "sequences" / "00" / "calib.txt", width=64, height=48)
    assert abs(back.baseline - s.rig.baseline) < 1e-9 and back.cameras[0].dist_model == "radtan"
    assert not back.cameras[0].has_distortion          # rectified pinhole: the lens is in rig.yaml only


def test_too_wide_a_fisheye_is_refused_before_anything_is_written(tmp_path, capsys):
    # f = 150 px on 640x480: the corners would see rays 153 deg off axis, beyond any pinhole canvas.
    from test_bad_input_cli import assert_one_line_exit_2, vo_testbed
    out = tmp_path / "g"
    code, _, err = vo_testbed(capsys, "generate", "--rig", "fisheye150", "--set", "rig.cam0.fx=150",
                              "--set", "rig.cam0.fy=150", "--scene", "indoor", "--duration", "0.2", "--out", out,
                              "--no-progress")
    assert_one_line_exit_2(code, err, "its image corners see rays more than 80 degrees off axis")
    assert not out.exists()




@pytest.mark.parametrize("parallel", [True, False])
def test_estimators_get_the_cv2_fisheye_rectified_view(tmp_path, parallel):
    # A fisheye dataset reaches the estimators rectified: pinhole rig, frames remapped by the cv2.fisheye
    # maps, ground truth of the rectified left camera (the same centre, turned by R0_rect^T; R0_rect = I
    # for a parallel pair).
    from vo.dataset.fisheye_view import RectifiedFisheyeView, for_estimators
    s = fisheye_synth(parallel=parallel)
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    ds = open_dataset(tmp_path / "ds")
    view = for_estimators(ds)
    assert isinstance(view, RectifiedFisheyeView) and view.images_are_rectified
    assert not any(c.has_distortion for c in view.rig.cameras)
    assert abs(view.rig.baseline - s.rig.baseline) < 1e-9 and len(view) == len(ds)
    raw, rect = ds.frame(1), view.frame(1)
    (mx, my), _ = view.rectification.maps()
    expect = cv2.remap(raw.left, mx, my, cv2.INTER_LINEAR)
    assert np.array_equal(rect.left, expect) and rect.t_ns == raw.t_ns
    assert (np.abs(view.rectification.R0_rect - np.eye(3)).max() > 1e-3) == (not parallel)
    gt, gt_r = ds.groundtruth_cam0(), view.groundtruth_cam0()
    np.testing.assert_allclose(gt_r.T[:, :3, 3], gt.T[:, :3, 3], atol=1e-12)
    np.testing.assert_allclose(gt_r.T[:, :3, :3], gt.T[:, :3, :3] @ view.rectification.R0_rect.T, atol=1e-12)
    radtan = open_dataset(_radtan_copy(tmp_path))
    assert for_estimators(radtan) is radtan


def _radtan_copy(tmp_path):
    s = Synth(n_frames=2)
    s.write(EurocWriter(tmp_path / "r", s.rig, s.metadata))
    return tmp_path / "r"


def test_bag_with_an_unsupported_distortion_model_is_refused(tmp_path):
    # A camera_info the reader cannot model (ROS "rational_polynomial") gets one line naming the topic,
    # instead of its 8 coefficients being read as radtan ones.
    import dataclasses as dc
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Writer
    from vo.errors import DatasetError
    s = Synth(n_frames=2)
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    export_rosbag(tmp_path / "ds", tmp_path / "ok.bag", kind="rosbag1")
    with AnyReader([tmp_path / "ok.bag"]) as reader, Writer(tmp_path / "bad.bag") as writer:
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=reader.typestore)
                 for c in reader.connections}
        for c, t, raw in reader.messages():
            if c.topic.endswith("camera_info"):
                msg = dc.replace(reader.deserialize(raw, c.msgtype), distortion_model="rational_polynomial")
                raw = reader.typestore.serialize_ros1(msg, c.msgtype)
            writer.write(conns[c.id], t, raw)
    with pytest.raises(DatasetError, match=r"/cam0/camera_info: distortion_model: only plumb_bob, equidistant "
                                           r"are supported, got 'rational_polynomial'"):
        open_dataset(tmp_path / "bad.bag")
