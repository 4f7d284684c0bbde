"""ROS bag export (sim.app.rosbag_export): every kind read back with rosbags' AnyReader must give
the dataset's own counts, timestamps, image bytes, IMU values, calibration and ground truth, exactly."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from test_dataset_synth import Synth

from sim.writers import EurocWriter, KittiWriter
from sim.app.rosbag_export import export_rosbag
from sim.errors import SimError
from vo.dataset import open_dataset

KINDS = [("rosbag1", "mcap"), ("rosbag2", "sqlite3"), ("rosbag2", "mcap")]


@pytest.fixture(scope="module")
def euroc_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("euroc") / "ds"
    s = Synth(n_frames=6)
    s.write(EurocWriter(out, s.rig, s.metadata))
    return out, s


def read_bag(path):
    """{topic: [(log time, message)]} and {topic: msgtype} of a bag, with AnyReader."""
    from rosbags.highlevel import AnyReader
    out, types = {}, {}
    with AnyReader([path]) as reader:
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
            types[conn.topic] = conn.msgtype
    return out, types


def stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def bag_path(tmp_path, kind):
    return tmp_path / ("ds.bag" if kind == "rosbag1" else "ds_bag2")


@pytest.mark.parametrize("kind,storage", KINDS)
def test_bag_reads_back_equal_to_dataset(euroc_dir, tmp_path, kind, storage):
    root, s = euroc_dir
    res = export_rosbag(root, bag_path(tmp_path, kind), kind=kind, storage=storage)
    msgs, types = read_bag(bag_path(tmp_path, kind))
    ds = open_dataset(root)
    n = len(s.t_frames)
    assert res.counts == {t: len(v) for t, v in msgs.items()}
    assert {t: len(v) for t, v in msgs.items()} == {
        "/tf_static": 1, "/cam0/camera_info": n, "/cam1/camera_info": n, "/cam0/image_raw": n,
        "/cam1/image_raw": n, "/imu0": len(s.t_imu), "/groundtruth/pose": len(s.t_imu), "/groundtruth/cam0": n}
    assert types["/cam0/image_raw"] == "sensor_msgs/msg/Image" and types["/imu0"] == "sensor_msgs/msg/Imu"
    for k in (0, 1):
        got = msgs[f"/cam{k}/image_raw"]
        assert [t for t, _ in got] == [stamp_ns(m) for _, m in got] == s.t_frames.tolist()
        for j, (_, m) in enumerate(got):
            assert m.encoding == "mono8" and (m.height, m.width, m.step) == (48, 64, 64)
            assert m.data.tobytes() == s.images[j][k].tobytes()          # written PNG is lossless
    imu = msgs["/imu0"]
    assert [t for t, _ in imu] == [stamp_ns(m) for _, m in imu] == s.t_imu.tolist()
    gyro = np.array([[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z] for _, m in imu])
    accel = np.array([[m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z] for _, m in imu])
    assert np.array_equal(gyro, s.gyro) and np.array_equal(accel, s.accel)         # repr floats round-trip
    c0 = msgs["/groundtruth/cam0"]
    p_c0 = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z] for _, m in c0])
    assert [t for t, _ in c0] == s.t_frames.tolist()
    assert np.allclose(p_c0, ds.groundtruth_cam0().T[:, :3, 3], atol=1e-12, rtol=0)


def test_bag_calibration_and_static_tf(euroc_dir, tmp_path):
    # camera_info carries the rig's intrinsics and the 5 OpenCV coefficients; /tf_static the body
    # poses of imu0, cam0, cam1 (quaternion back to the rotation within 1e-12).
    from rigs.geometry import R_from_quat_wxyz
    root, s = euroc_dir
    export_rosbag(root, tmp_path / "c.bag", kind="rosbag1")
    msgs, _ = read_bag(tmp_path / "c.bag")
    for k in (0, 1):                      # each camera's own info (frame id, P of the rectified pair aside)
        assert {m.header.frame_id for _, m in msgs[f"/cam{k}/camera_info"]} == {f"cam{k}"}
    info = msgs["/cam1/camera_info"][0][1]
    cam = s.rig.cameras[1]
    assert info.distortion_model == "plumb_bob" and list(info.D) == list(cam.dist)
    assert np.allclose(np.reshape(info.K, (3, 3)), [[cam.fx, 0, cam.cx], [0, cam.fy, cam.cy], [0, 0, 1]])
    tf = msgs["/tf_static"][0][1]
    assert msgs["/tf_static"][0][0] == min(s.t_frames[0], s.t_imu[0])
    want = {"imu0": s.rig.imu.T_b_i_array, "cam0": s.rig.cameras[0].T_b_c_array, "cam1": cam.T_b_c_array}
    for tr in tf.transforms:
        q = tr.transform.rotation
        T = want[tr.child_frame_id]
        assert tr.header.frame_id == "body"
        assert np.allclose(R_from_quat_wxyz(np.array([q.w, q.x, q.y, q.z])), T[:3, :3], atol=1e-12)
        v = tr.transform.translation
        assert np.allclose([v.x, v.y, v.z], T[:3, 3], atol=1e-15)
    assert sorted(tr.child_frame_id for tr in tf.transforms) == ["cam0", "cam1", "imu0"]


def test_rgb_images_are_rgb8(tmp_path):
    s = Synth(n_frames=2, rgb=True)
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    export_rosbag(tmp_path / "ds", tmp_path / "rgb.bag", kind="rosbag1")
    msgs, _ = read_bag(tmp_path / "rgb.bag")
    m = msgs["/cam1/image_raw"][1][1]
    assert m.encoding == "rgb8" and m.step == 64 * 3
    assert m.data.tobytes() == s.images[1][1].tobytes()


def test_kitti_bag_has_rectified_projection_and_no_imu(tmp_path):
    # A KITTI folder: rectified images as stored, P of cam1 = K [I | -B e_x] (P[0,3] = -fx B), no /imu0.
    s = Synth(n_frames=3)
    s.write(KittiWriter(tmp_path / "k", s.rig, s.metadata))
    export_rosbag(tmp_path / "k", tmp_path / "k_bag", kind="rosbag2", storage="mcap")
    msgs, _ = read_bag(tmp_path / "k_bag")
    assert "/imu0" not in msgs and len(msgs["/cam0/image_raw"]) == 3
    info = msgs["/cam1/camera_info"][0][1]
    P = np.reshape(info.p, (3, 4))
    assert np.isclose(P[0, 3], -P[0, 0] * s.rig.baseline, rtol=1e-9)
    stored = cv2.imread(str(tmp_path / "k/sequences/00/image_1/000002.png"), cv2.IMREAD_UNCHANGED)
    assert msgs["/cam1/image_raw"][2][1].data.tobytes() == stored.tobytes()


def test_wheels_topic_in_radians(euroc_dir, tmp_path):
    import dataclasses
    import shutil
    from rigs.rig_yaml import save_rig
    from rigs.model import Wheels
    root, s = euroc_dir
    ds = tmp_path / "w"
    shutil.copytree(root, ds)
    save_rig(dataclasses.replace(s.rig, wheels=Wheels(ticks_per_rev=1000)), ds / "rig.yaml")
    (ds / "wheels.csv").write_text("#timestamp [ns],left_ticks,right_ticks\n"
                                   f"{s.t_imu[0]},0,0\n{s.t_imu[4]},250,-500\n")
    export_rosbag(ds, tmp_path / "w.bag", kind="rosbag1")
    msgs, _ = read_bag(tmp_path / "w.bag")
    (t, m) = msgs["/wheels"][1]
    assert t == s.t_imu[4] and list(m.name) == ["left_wheel", "right_wheel"]
    assert np.allclose(m.position, [np.pi / 2, -np.pi], rtol=1e-15)


def test_existing_output_and_bad_kind_are_refused(euroc_dir, tmp_path):
    root, _ = euroc_dir
    (tmp_path / "x.bag").write_text("")
    with pytest.raises(SimError, match="already exists"):
        export_rosbag(root, tmp_path / "x.bag", kind="rosbag1")
    with pytest.raises(SimError, match="--to: unknown"):
        export_rosbag(root, tmp_path / "y.bag", kind="rosbag3")
    with pytest.raises(SimError, match="--storage"):
        export_rosbag(root, tmp_path / "y", kind="rosbag2", storage="leveldb")
    with pytest.raises(SimError, match=r"named \*.bag"):
        export_rosbag(root, tmp_path / "y.bag", kind="rosbag2")
    with pytest.raises(SimError, match=r"named \*.bag"):
        export_rosbag(root, tmp_path / "y", kind="rosbag1")
    assert not (tmp_path / "y").exists() and not (tmp_path / "y.bag").exists()


def test_rendered_dataset_bags_have_the_dataset_counts_and_times(campus_short, tmp_path):
    # A rendered 6 s dataset as rosbag1 and rosbag2 (MCAP): per topic, the message count, the log
    # times and the header stamps equal the dataset's frame / IMU / ground-truth times; images are
    # the stored PNGs' pixels.
    ds = open_dataset(campus_short)
    want = {"/cam0/image_raw": ds.frame_times_ns, "/cam1/camera_info": ds.frame_times_ns,
            "/imu0": ds.imu.t_ns, "/groundtruth/pose": ds.groundtruth.t_ns, "/groundtruth/cam0": ds.frame_times_ns}
    for kind, storage in (("rosbag1", "mcap"), ("rosbag2", "mcap")):
        path = bag_path(tmp_path, kind)
        export_rosbag(campus_short, path, kind=kind, storage=storage)
        msgs, _ = read_bag(path)
        for topic, t in want.items():
            assert [x for x, _ in msgs[topic]] == t.tolist(), (kind, topic)
            assert [stamp_ns(m) for _, m in msgs[topic]] == t.tolist(), (kind, topic)
        last = msgs["/cam1/image_raw"][-1][1]
        stored = cv2.imread(str(ds.image_files(len(ds) - 1)[1]), cv2.IMREAD_UNCHANGED)
        assert last.data.tobytes() == stored.tobytes() and (last.height, last.width) == stored.shape


def test_export_command(euroc_dir, tmp_path, capsys):
    # `vo-testbed export`: JSON counts on success; an existing --out is bad input (exit 2, one line).
    import json
    from sim.app.cli import main
    root, s = euroc_dir
    main(["export", "--dataset", str(root), "--to", "rosbag2", "--storage", "sqlite3", "--out",
          str(tmp_path / "b2"), "--json"])
    res = json.loads(capsys.readouterr().out)
    assert res["storage"] == "sqlite3" and res["counts"]["/imu0"] == len(s.t_imu)
    assert list((tmp_path / "b2").glob("*.db3"))
    with pytest.raises(SystemExit) as exc:
        main(["export", "--dataset", str(root), "--to", "rosbag2", "--out", str(tmp_path / "b2")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.startswith("error: --out:") and err.count("\n") == 1


@pytest.mark.parametrize("kind,storage", [("rosbag1", "mcap"), ("rosbag2", "mcap")])
def test_no_truth_bag_holds_the_sensor_topics_only(euroc_dir, tmp_path, kind, storage, capsys):
    # `export --no-truth`: the same sensor messages as the full bag, and no /groundtruth/* topic.
    from sim.app.cli import main
    root, s = euroc_dir
    full, bare = tmp_path / ("full.bag" if kind == "rosbag1" else "full"), \
        tmp_path / ("bare.bag" if kind == "rosbag1" else "bare")
    export_rosbag(root, full, kind=kind, storage=storage)
    main(["export", "--dataset", str(root), "--to", kind, "--out", str(bare), "--no-truth", "--json"])
    assert "/groundtruth" not in capsys.readouterr().out
    a, _ = read_bag(full)
    b, _ = read_bag(bare)
    assert set(b) == set(a) - {"/groundtruth/pose", "/groundtruth/cam0"} and "/groundtruth/pose" in a
    for topic in b:
        assert [t for t, _ in b[topic]] == [t for t, _ in a[topic]]
    assert [m.data.tobytes() for _, m in b["/cam1/image_raw"]] == [m.data.tobytes() for _, m in a["/cam1/image_raw"]]
