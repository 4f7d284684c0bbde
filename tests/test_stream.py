"""``sim.stream(config)`` yields what ``generate`` writes for the same configuration: the frames' images
equal the PNGs, the IMU samples between frames the rows of imu0/data.csv (with a simulated clock offset),
the truth the ground-truth files."""
import cv2
import numpy as np
import pytest

import sim
from rigs.geometry import quat_wxyz_from_R
from sim.generate import generate
from sim.scenarios import get_scenario


@pytest.mark.slow
def test_stream_equals_the_generated_dataset(tmp_path):
    cfg = get_scenario("smoke").with_value("duration_s", 0.3).with_overrides(["imu.time_offset_ms=3"])
    generate(cfg, tmp_path / "ds", progress=False)
    mav0 = tmp_path / "ds/mav0"
    frames = list(sim.stream(cfg))
    rows = [ln.split(",") for ln in (mav0 / "cam0/data.csv").read_text().splitlines()[1:]]
    assert len(frames) == len(rows) >= 3
    for f, row in zip(frames, rows):
        assert f.t_ns == int(row[0])
        for cam in (0, 1):
            png = cv2.imread(str(mav0 / f"cam{cam}/data/{row[1]}"), cv2.IMREAD_UNCHANGED)
            assert np.array_equal(png, f.images[cam]), (f.k, cam)
    imu = np.loadtxt(mav0 / "imu0/data.csv", delimiter=",", comments="#", dtype=np.float64)
    t_imu = np.loadtxt(mav0 / "imu0/data.csv", delimiter=",", comments="#", usecols=0, dtype=np.int64)
    got_t = np.concatenate([f.imu_t_ns for f in frames])
    n = len(got_t)
    assert np.array_equal(got_t, t_imu[:n]) and np.all(t_imu[n:] > frames[-1].t_ns)   # the rest follow the last frame
    np.testing.assert_array_equal(np.concatenate([f.gyro for f in frames]), imu[:n, 1:4])
    np.testing.assert_array_equal(np.concatenate([f.accel for f in frames]), imu[:n, 4:7])
    assert np.all(np.diff(got_t) > 0) and frames[1].imu_t_ns[0] > frames[0].t_ns
    gt = np.loadtxt(mav0 / "state_groundtruth_estimate0/data.csv", delimiter=",", comments="#")
    T = np.concatenate([f.truth_T_w_i for f in frames])
    np.testing.assert_array_equal(T[:, :3, 3], gt[:n, 1:4])
    np.testing.assert_allclose(quat_wxyz_from_R(T[:, :3, :3]), gt[:n, 4:8], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(np.concatenate([f.truth_v_w for f in frames]), gt[:n, 8:11])
    np.testing.assert_array_equal(np.concatenate([f.truth_b_g for f in frames]), gt[:n, 11:14])
    tum = np.loadtxt(tmp_path / "ds/groundtruth_tum.txt")
    np.testing.assert_allclose([f.T_w_c0[:3, 3] for f in frames], tum[:, 1:4], rtol=0, atol=1e-9)
    assert len(frames[0].imu_t_ns) == 0                      # td = +3 ms: the first sample is stamped after frame 0
    assert frames[1].imu_t_ns[0] - frames[1].truth_t_ns[0] == 3_000_000          # t_imu = t_cam + td


def test_stream_without_images_is_refused():
    from sim.errors import SimError
    with pytest.raises(SimError, match="images: false"):
        sim.stream(get_scenario("smoke").with_value("duration_s", 0.1).with_value("images", False))
