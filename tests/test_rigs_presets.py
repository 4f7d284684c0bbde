"""Presets: load, validate, match the seed papers' numbers and the checked-in YAML files."""
import numpy as np
import pytest

from rigs import RigError
from rigs.rig_yaml import load_rig
from rigs.presets import PRESET_DIR, R_B_C_FORWARD, get_rig, rig_names
from rigs.geometry import opk_deg_from_R


@pytest.mark.parametrize("name", rig_names())
def test_preset_loads_and_matches_yaml_file(name):
    rig = get_rig(name)
    assert rig.name == name and rig.is_stereo
    # The YAML files are written from the code; an exact match shows they are not stale.
    assert load_rig(PRESET_DIR / f"{name}.yaml") == rig
    # Left camera on +y (left), right camera on -y, both looking forward-ish (+x of body).
    T_b_c0, T_b_c1 = (c.T_b_c_array for c in rig.cameras)
    assert T_b_c0[1, 3] > 0 > T_b_c1[1, 3]
    assert T_b_c0[:3, 2] @ [1, 0, 0] > 0.9
    # IMU 0.2 m below the cameras' mast point, axes along b.
    np.testing.assert_allclose(rig.imu.T_b_i_array[:3, :3], np.eye(3))
    assert rig.imu.T_b_i_array[2, 3] == pytest.approx(T_b_c0[2, 3] - 0.2, abs=1e-12)


def test_cart27_matches_seed000_tables():
    rig = get_rig("cart27")
    # Table 3 baseline is |(0.2857, 0.0005, -0.0041)| = 0.285730 m (printed rounded as 0.2857).
    assert rig.baseline == pytest.approx(0.28573, abs=5e-6)
    # R_c0_c1 round-trips to Table 3's omega, phi, kappa; float64 round trip -> 1e-9 deg.
    np.testing.assert_allclose(opk_deg_from_R(rig.T_c0_c1[:3, :3]), [-0.01406, -0.75671, 0.80437], atol=1e-9)
    np.testing.assert_allclose(rig.T_c0_c1[:3, 3], [0.2857, 0.0005, -0.0041], atol=1e-12)
    c0, c1 = rig.cameras
    assert (c0.width, c0.height) == (720, 480)
    # Scaled by s = 0.15 with f' = s f and c' = s (c + 0.5) - 0.5.
    assert c0.fx == pytest.approx(0.15 * 3362.10) and c1.fx == pytest.approx(0.15 * 3366.02)
    assert c0.cx == pytest.approx(0.15 * 2407.2 - 0.5) and c0.cy == pytest.approx(0.15 * 1602.25 - 0.5)
    # Table 2 order k1, k2, k3, p1, p2 mapped to OpenCV (k1, k2, p1, p2, k3).
    assert c0.dist == (0.0176, -0.0356, -0.0006, -0.0005, 0.0507)
    assert c1.dist == (0.0176, -0.0373, -0.0001, 0.0008, 0.0444)
    # Mast: c0 at 1.2 m height, 0.3 m forward, half a baseline to the left, looking forward.
    np.testing.assert_allclose(c0.T_b_c_array[:3, 3], [0.3, rig.baseline / 2, 1.2], atol=1e-12)
    np.testing.assert_allclose(c0.T_b_c_array[:3, :3], R_B_C_FORWARD)
    assert rig.camera_rate_hz == 10.0 and rig.imu.name == "euroc-adis16448"


def test_stereo27_is_ideal_parallel_pair():
    rig = get_rig("stereo27")
    np.testing.assert_allclose(rig.T_c0_c1, np.array([[1, 0, 0, 0.27], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]),
                               atol=1e-15)
    for c in rig.cameras:
        assert (c.width, c.height, c.fx, c.fy, c.cx, c.cy) == (752, 480, 458.0, 458.0, 375.5, 239.5)
        assert not c.has_distortion
    assert rig.camera_rate_hz == 20.0


def test_yutu_navcam_tilt_and_fov():
    rig = get_rig("yutu-navcam")
    c0 = rig.cameras[0]
    fov_deg = np.degrees(2 * np.arctan(c0.width / 2 / c0.fx))
    assert fov_deg == pytest.approx(46.6, abs=0.05)     # seed 001 quotes 46.6 deg
    z_b = c0.T_b_c_array[:3, 2]                          # optical axis in body frame
    assert np.degrees(np.arctan2(-z_b[2], z_b[0])) == pytest.approx(20.0, abs=1e-9)   # 20 deg down
    assert c0.T_b_c_array[2, 3] == pytest.approx(1.5) and rig.mount == "pan-tilt mast"
    assert rig.baseline == pytest.approx(0.27, abs=1e-12) and rig.camera_rate_hz == 1.0


def test_unknown_preset_names_valid_choices():
    with pytest.raises(RigError) as e:
        get_rig("cart28")
    msg = str(e.value)
    assert "\n" not in msg and "cart28" in msg and "cart27" in msg and "stereo27" in msg


def test_get_rig_with_overrides():
    rig = get_rig("stereo27", ["baseline=0.12"])
    assert rig.baseline == pytest.approx(0.12, abs=1e-15)


def test_cart27_yaml_states_the_scale_and_get_rig_reads_paths(tmp_path):
    text = (PRESET_DIR / "cart27.yaml").read_text()
    assert text.startswith("#") and "s = 0.15" in text and "4800x3200 -> 720x480" in text
    assert get_rig(str(PRESET_DIR / "cart27.yaml")) == get_rig("cart27")
