"""Hand-written real EuRoC (MH_01 style) and real KITTI odometry layouts open through open_dataset."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from vo.dataset import open_dataset
from rigs.geometry import R_from_quat_wxyz, make_T

# Values copied from EuRoC MH_01_easy mav0/cam0/sensor.yaml (T_BS of cam0 in the IMU body frame).
CAM0_T_BS = [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
             0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
             -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
             0.0, 0.0, 0.0, 1.0]
CAM1_T_BS = [0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556,
             0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024,
             -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038,
             0.0, 0.0, 0.0, 1.0]


def cam_yaml(T_BS, intr, dist):
    rows = ",\n         ".join(", ".join(repr(v) for v in T_BS[4 * r:4 * r + 4]) for r in range(4))
    return f"""%YAML:1.0
# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [{rows}]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: {intr} #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: {dist}
"""


# real EuRoC mav0/imu0/sensor.yaml (shared fixture)
IMU_YAML = (Path(__file__).parent / "fixtures" / "euroc_imu0_sensor.yaml").read_text()

GT_HEADER = ("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
             "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
             "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
             "b_a_RS_S_z [m s^-2]")
T_CAM = 1403636579763555584 + 50_000_000 * np.arange(5, dtype=np.int64)


@pytest.fixture
def real_euroc(tmp_path):
    rng = np.random.default_rng(11)
    mav0 = tmp_path / "MH_01_easy" / "mav0"
    for k, T_BS in enumerate((CAM0_T_BS, CAM1_T_BS)):
        d = mav0 / f"cam{k}"
        (d / "data").mkdir(parents=True)
        (d / "sensor.yaml").write_text(cam_yaml(T_BS, "[458.654, 457.296, 367.215, 248.375]",
                                                "[-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]"))
        times = T_CAM if k == 0 else T_CAM[:4]            # cam1 lacks the last frame
        for t in times:
            cv2.imwrite(str(d / "data" / f"{t}.png"), rng.integers(0, 256, (480, 752), dtype=np.uint8))
        (d / "data.csv").write_text("#timestamp [ns],filename\n" + "".join(f"{t},{t}.png\r\n" for t in times))
    (mav0 / "imu0").mkdir()
    (mav0 / "imu0" / "sensor.yaml").write_text(IMU_YAML)
    t_imu = T_CAM[0] + 5_000_000 * np.arange(40)
    (mav0 / "imu0" / "data.csv").write_text(
        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
        "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
        + "".join(f"{t},-0.0991,0.1382,0.0251,8.1,-0.2,-3.5\n" for t in t_imu))
    # gt starts after frame 0 (as in real EuRoC, Vicon starts late): frame 0 must be dropped.
    t_gt = T_CAM[0] + 10_000_000 + 5_000_000 * np.arange(40)
    ang = 0.3 * np.arange(40) / 40
    (mav0 / "state_groundtruth_estimate0").mkdir()
    (mav0 / "state_groundtruth_estimate0" / "data.csv").write_text(GT_HEADER + "\n" + "".join(
        f"{t},{4.6 + 0.1 * i},{-1.8},{0.79},{np.cos(a / 2)},{0.0},{0.0},{np.sin(a / 2)},0,0,0,0,0,0,0,0,0\n"
        for i, (t, a) in enumerate(zip(t_gt, ang))))
    return tmp_path / "MH_01_easy", t_gt, ang


def test_real_euroc_body_is_imu_frame(real_euroc):
    root, _, _ = real_euroc
    for path in (root, root / "mav0"):
        ds = open_dataset(path)
        assert ds.kind == "euroc" and ds.name == "MH_01_easy" and ds.metadata == {} and ds.gcps == []
        assert np.allclose(ds.rig.cameras[0].T_b_c_array, np.reshape(CAM0_T_BS, (4, 4)), atol=1e-11)
        assert np.allclose(ds.rig.imu.T_b_i_array, np.eye(4))
        assert abs(ds.rig.cameras[0].fx - 458.654) < 1e-12 and ds.rig.cameras[0].dist[4] == 0.0
        assert len(ds) == 4 and "dropped 1 cam0" in ds.warnings[0]
        assert ds.frame(0).left.shape == (480, 752)
        assert ds.imu.gyro.shape == (40, 3) and ds.imu.accel[0, 0] == 8.1


def test_real_euroc_groundtruth_cam0_interpolates_and_drops(real_euroc):
    root, t_gt, ang = real_euroc
    ds = open_dataset(root)
    gt = ds.groundtruth
    assert gt.frame == "i" and np.array_equal(gt.t_ns, t_gt)
    c0 = ds.groundtruth_cam0()
    assert np.array_equal(c0.t_ns, T_CAM[1:4])            # frame 0 precedes the gt; frame 4 unpaired
    # Frame k at T_CAM[k] = t_gt[0] + (10 k - 2) * 5 ms: gt index 10k - 2 exactly (no interpolation
    # error in position; yaw is linear in time, so SLERP is exact too).
    for j, k in enumerate((1, 2, 3)):
        i = 10 * k - 2
        T_w_i = make_T(R_from_quat_wxyz([np.cos(ang[i] / 2), 0, 0, np.sin(ang[i] / 2)]), (4.6 + 0.1 * i, -1.8, 0.79))
        assert np.allclose(c0.T[j], T_w_i @ np.reshape(CAM0_T_BS, (4, 4)), atol=1e-9)


def test_real_kitti_sequence(tmp_path):
    rng = np.random.default_rng(5)
    seq = tmp_path / "dataset" / "sequences" / "05"
    P0 = "7.070912e+02 0.000000e+00 6.018873e+02 0.000000e+00 0.000000e+00 7.070912e+02 1.831104e+02 " \
         "0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00"
    P1 = P0.replace("6.018873e+02 0.000000e+00", "6.018873e+02 -3.798145e+02", 1)
    (seq / "image_0").mkdir(parents=True)
    (seq / "image_1").mkdir()
    (seq / "calib.txt").write_text(f"P0: {P0}\nP1: {P1}\nP2: {P0}\nP3: {P1}\nTr: {P0}\n")
    (seq / "times.txt").write_text("".join(f"{0.1036 * k:.6e}\n" for k in range(3)))
    for k in range(3):
        for c in (0, 1):
            cv2.imwrite(str(seq / f"image_{c}" / f"{k:06d}.png"), rng.integers(0, 256, (376, 1241), dtype=np.uint8))
    poses = tmp_path / "dataset" / "poses"
    poses.mkdir()
    (poses / "05.txt").write_text("".join(f"1 0 0 0 0 1 0 0 0 0 1 {0.8 * k}\n" for k in range(3)))
    ds = open_dataset(seq)
    assert ds.kind == "kitti" and len(ds) == 3 and ds.images_are_rectified
    assert abs(ds.rig.baseline - 379.8145 / 707.0912) < 1e-12
    assert (ds.rig.cameras[1].width, ds.rig.cameras[1].height) == (1241, 376)
    assert np.array_equal(ds.frame_times_ns, [0, 103_600_000, 207_200_000])
    assert np.allclose(ds.groundtruth.positions[:, 2], [0, 0.8, 1.6])
    with pytest.raises(Exception, match="several KITTI sequences|open one"):
        (tmp_path / "dataset" / "sequences" / "06").mkdir()
        open_dataset(tmp_path / "dataset")
