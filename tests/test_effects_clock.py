"""Camera-IMU time offset (``imu.time_offset_ms``, t_imu = t_cam + td) and frame timestamp jitter."""
import numpy as np
import pytest
import yaml

from sim.generate_config import GenerateConfig
from sim.generate import generate, resolve
from sim.sensors.effects_timing import frame_stamps_ns

TD_MS = 7.3


@pytest.fixture(scope="module")
def offset_dataset(tmp_path_factory):
    """6 s of campus IMU (no images, noise-free) with a 7.3 ms offset and 200 us frame jitter (a few seconds)."""
    cfg = GenerateConfig(scene="campus", rig="cart27", duration_s=6.0, images=False, ideal=True).with_overrides(
        [f"imu.time_offset_ms={TD_MS}", "camera.timestamp_jitter_us=200"])
    out = tmp_path_factory.mktemp("offset")
    generate(cfg, out, progress=False)
    return cfg, out


def _imu(out):
    d = np.loadtxt(out / "mav0/imu0/data.csv", delimiter=",", comments="#", dtype=np.float64)
    t = np.loadtxt(out / "mav0/imu0/data.csv", delimiter=",", comments="#", usecols=0, dtype=np.int64)
    return t, d[:, 1:4]


def test_imu_stamps_are_true_times_plus_the_offset(offset_dataset):
    cfg, out = offset_dataset
    t, _ = _imu(out)
    setup = resolve(cfg)
    assert np.array_equal(t - setup.imu_t_ns, np.full(len(t), int(round(TD_MS * 1e6))))
    truth = yaml.safe_load((out / "sensor_effects.yaml").read_text())
    assert truth["imu_time_offset_ns"] == int(round(TD_MS * 1e6))


def test_cross_correlation_of_gyro_and_true_rate_recovers_the_offset(offset_dataset):
    """The lag maximising the correlation of the written gyro (at its stamps) with the true body rate
    (evaluated continuously at stamp - lag) is the set offset, to 0.05 ms (1 % of one 5 ms IMU sample)."""
    cfg, out = offset_dataset
    t, gyro = _imu(out)
    setup = resolve(cfg)
    R_b_i = setup.rig.imu.T_b_i_array[:3, :3]
    keep = (t > t[0] + 30_000_000) & (t < t[-1] - 30_000_000)       # lags up to 30 ms stay inside the run

    def corr(lag_ms):
        om_b = setup.trajectory.states(t[keep] - int(round(lag_ms * 1e6))).omega_b
        true_i = om_b @ R_b_i
        a, b = gyro[keep] - gyro[keep].mean(0), true_i - true_i.mean(0)
        return (a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum())

    assert np.std(gyro[keep], axis=0).max() > 1e-3                 # the motion excites the gyro
    coarse = np.arange(-25.0, 25.01, 1.0)
    best = coarse[np.argmax([corr(x) for x in coarse])]
    fine = np.arange(best - 1.0, best + 1.0001, 0.02)
    lag = fine[np.argmax([corr(x) for x in fine])]
    assert lag == pytest.approx(TD_MS, abs=0.05)


def test_frame_stamps_carry_the_jitter_and_truth_the_true_time(offset_dataset):
    cfg, out = offset_dataset
    setup = resolve(cfg)
    e = setup.frame_stamp_ns - setup.frame_t_ns
    assert e.std() == pytest.approx(200e3, rel=0.25)                # 61 frames: sample std within 25 %
    assert np.all(np.diff(setup.frame_stamp_ns) > 0)
    stamps_s = [ln.split()[0] for ln in (out / "groundtruth_tum.txt").read_text().splitlines() if ln[0] != "#"]
    rows = np.array([int(s.replace(".", "")) for s in stamps_s], np.int64)
    assert np.array_equal(rows, setup.frame_stamp_ns)               # truth keyed by the written stamp
    rng = np.random.default_rng(1)
    assert np.array_equal(frame_stamps_ns(setup.frame_t_ns, 0.0, rng), setup.frame_t_ns)
