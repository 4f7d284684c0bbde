"""Kalibr files of a generated dataset read back through the CLI: ``generate --rig camchain-imucam.yaml
--imu imu.yaml`` makes the same rig (to 1e-12) as the dataset's own rig.yaml."""
import numpy as np
import pytest

from rigs.rig_yaml import load_rig
from test_cli_integration import run_cli
from test_rigs_calib_io import _assert_same_rig


@pytest.mark.slow
def test_generate_with_kalibr_rig_gives_the_rig_of_the_dataset(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    r = run_cli("generate", "--scene", "campus", "--rig", "stereo27", "--duration", "0.2", "--no-images",
                "--set", "imu.time_offset_ms=2.5", "--out", str(a), "--no-progress")
    assert r.returncode == 0, r.stderr
    chain, imu = a / "mav0/camchain-imucam.yaml", a / "mav0/imu.yaml"
    assert "timeshift_cam_imu: 0.0025\n" in chain.read_text()          # the simulated td, Kalibr's sign
    r = run_cli("generate", "--scene", "campus", "--rig", str(chain), "--imu", str(imu), "--duration", "0.2",
                "--no-images", "--set", "camera_rate_hz=20", "--out", str(b), "--no-progress")
    assert r.returncode == 0, r.stderr
    _assert_same_rig(load_rig(a / "rig.yaml"), load_rig(b / "rig.yaml"))
    # the IMU stream is the same (same seed, same noise densities, rate and body frame)
    assert (a / "mav0/state_groundtruth_estimate0/data.csv").read_bytes() == \
        (b / "mav0/state_groundtruth_estimate0/data.csv").read_bytes()


def test_imu_without_kalibr_rig_is_refused(tmp_path):
    r = run_cli("generate", "--imu", str(tmp_path / "imu.yaml"), "--no-images", "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "--imu imu.yaml goes with --rig camchain-imucam.yaml" in r.stderr


def test_not_a_camchain_with_imu_names_the_file(tmp_path):
    (tmp_path / "imu.yaml").write_text("imu0: {}\n")
    r = run_cli("generate", "--rig", "stereo27", "--imu", str(tmp_path / "imu.yaml"), "--no-images",
                "--out", str(tmp_path / "x"))
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "stereo27" in lines[0], r.stderr
