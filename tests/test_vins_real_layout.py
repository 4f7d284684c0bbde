"""`vins` on a real EuRoC layout (mav0/camK/sensor.yaml, imu0/sensor.yaml + data.csv, no rig.yaml): the same
reader path as real recordings. The layout is made from a rendered dataset, so its run must equal the run on
our own layout (same images, IMU samples and calibration; body = IMU frame as in real EuRoC)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import shutil

import numpy as np
import pytest

from rigs.calib_io import write_euroc_camera_yaml, write_euroc_imu_yaml
from vo.dataset.open import open_dataset
from vo.estimators.runner import run_estimator


def to_real_euroc(src, dst):
    """Copy dataset ``src`` as a real EuRoC recording ``dst/mav0``: T_BS of each camera in the IMU frame."""
    ds = open_dataset(src)
    rig = ds.rig
    T_i_b = np.linalg.inv(rig.imu.T_b_i_array)
    for k, cam in enumerate(rig.cameras):
        d = dst / "mav0" / f"cam{k}"
        shutil.copytree(src / "mav0" / f"cam{k}" / "data", d / "data")
        shutil.copy(src / "mav0" / f"cam{k}" / "data.csv", d / "data.csv")
        write_euroc_camera_yaml(d / "sensor.yaml", cam, T_i_b @ cam.T_b_c_array, rig.camera_rate_hz)
    (dst / "mav0" / "imu0").mkdir()
    shutil.copy(src / "mav0" / "imu0" / "data.csv", dst / "mav0" / "imu0" / "data.csv")
    write_euroc_imu_yaml(dst / "mav0" / "imu0" / "sensor.yaml", rig.imu, np.eye(4))
    return dst


def test_vins_on_real_euroc_layout_equals_own_layout(campus_short, tmp_path):
    real = open_dataset(to_real_euroc(campus_short, tmp_path / "MH_sim"))
    assert real.ours is False and real.imu is not None and len(real) == len(open_dataset(campus_short))
    a = run_estimator("vins", real, progress=False, max_frames=30)
    b = run_estimator("vins", open_dataset(campus_short), progress=False, max_frames=30)
    T_a, T_b = np.array([f.T_o_c0 for f in a.frames]), np.array([f.T_o_c0 for f in b.frames])
    assert np.all(np.isfinite(T_a)) and np.allclose(T_a, T_b, atol=1e-9)
    assert [f.status for f in a.frames] == [f.status for f in b.frames]
    assert [f.n_features for f in a.frames] == [f.n_features for f in b.frames]
    assert all(f.cov is not None and np.all(np.isfinite(f.cov)) for f in a.frames)


@pytest.mark.slow
def test_vins_on_real_euroc_layout_after_initialisation(tmp_path):
    """10 s of ideal campus (initialises near frame 75): the post-initialisation poses on the real layout equal
    those on our own layout to 1e-6 m (identical inputs up to the YAML round trip of the calibration)."""
    from sim.generate_config import GenerateConfig
    from sim.generate import generate
    src = tmp_path / "own"
    generate(GenerateConfig(scene="campus", rig="cart27", duration_s=10.0, seed=0, ideal=True), src, progress=False)
    a = run_estimator("vins", open_dataset(to_real_euroc(src, tmp_path / "real")), progress=False)
    b = run_estimator("vins", open_dataset(src), progress=False)
    post = [k for k, f in enumerate(b.frames) if f.status != "init"]
    assert len(post) > 10
    T_a, T_b = np.array([f.T_o_c0 for f in a.frames]), np.array([f.T_o_c0 for f in b.frames])
    assert np.all(np.isfinite(T_a)) and np.abs(T_a[post, :3, 3] - T_b[post, :3, 3]).max() < 1e-6
