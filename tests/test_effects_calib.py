"""Imperfect calibration: the written calibration is the true one plus the drawn perturbation; the images
are those of the true calibration."""
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from rigs.presets import get_rig
from rigs.rig_yaml import load_rig
from sim.generate_config import CalibError, GenerateConfig
from sim.rng import stream
from sim.sensors.calib_error import perturb_rig

ERR = CalibError(focal_ppm=500.0, principal_px=0.4, dist_rel=0.05, extrinsic_rot_deg=0.1, extrinsic_trans_mm=1.0)


def test_perturbation_is_the_scaled_draw():
    rig = get_rig("cart27")
    z = np.random.default_rng(3).standard_normal((len(rig.cameras), 15))
    bad, drawn = perturb_rig(rig, ERR, np.random.default_rng(3))
    assert np.array_equal(drawn, z)
    for c, p, zk in zip(rig.cameras, bad.cameras, z):
        assert p.fx / c.fx - 1 == pytest.approx(ERR.focal_ppm * 1e-6 * zk[0], rel=1e-9)
        assert p.fy / c.fy - 1 == pytest.approx(ERR.focal_ppm * 1e-6 * zk[1], rel=1e-9)
        assert (p.cx - c.cx, p.cy - c.cy) == pytest.approx(tuple(ERR.principal_px * zk[2:4]), abs=1e-12)
        assert np.allclose(np.array(p.dist), np.array(c.dist) * (1 + ERR.dist_rel * zk[4:9]), atol=0)
        T_c_p = np.linalg.inv(c.T_b_c_array) @ p.T_b_c_array           # the error in the camera's own frame
        rotvec_deg = np.rad2deg(Rotation.from_matrix(T_c_p[:3, :3]).as_rotvec())
        assert np.allclose(rotvec_deg, ERR.extrinsic_rot_deg * zk[9:12], atol=1e-10)
        assert np.allclose(T_c_p[:3, 3], ERR.extrinsic_trans_mm * 1e-3 * zk[12:15], atol=1e-12)


def test_no_error_draws_nothing():
    rig = get_rig("cart27")
    rng = np.random.default_rng(0)
    same, _ = perturb_rig(rig, CalibError(), rng)
    assert same is rig and rng.standard_normal() == np.random.default_rng(0).standard_normal()


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """0.4 s of the smoke scenario with and without calibration error (about 20 s)."""
    from sim.generate import generate
    from sim.scenarios import get_scenario
    base = get_scenario("smoke").with_value("duration_s", 0.4)
    bad = base.with_overrides([f"calib_error.{k}={v}" for k, v in vars(ERR).items()])
    out = {}
    for name, cfg in (("true", base), ("bad", bad)):
        out[name] = tmp_path_factory.mktemp(name)
        generate(cfg, out[name], progress=False)
    return base, out


@pytest.mark.slow
def test_written_calibration_is_perturbed_and_images_are_true(pair):
    cfg, out = pair
    expected, _ = perturb_rig(cfg.rig, ERR, stream(cfg.seed, "calib_error"))
    assert load_rig(out["bad"] / "rig.yaml") == expected
    assert load_rig(out["bad"] / "rig_true.yaml") == load_rig(out["true"] / "rig.yaml")
    sensor = [(out[k] / "mav0/cam1/sensor.yaml").read_text() for k in ("true", "bad")]
    assert sensor[0] != sensor[1]                                   # the EuRoC calibration files too
    chain = [(out[k] / "mav0/camchain-imucam.yaml").read_text() for k in ("true", "bad")]
    assert chain[0] != chain[1]                                     # and the Kalibr camchain
    pngs = sorted((out["true"] / "mav0/cam0/data").glob("*.png")) + sorted((out["true"] / "mav0/cam1/data").glob("*.png"))
    assert len(pngs) >= 8
    for p in pngs:
        assert p.read_bytes() == (out["bad"] / p.relative_to(out["true"])).read_bytes()
    drawn = yaml.safe_load((out["bad"] / "sensor_effects.yaml").read_text())["calib_error"]
    assert drawn["cam0"]["fx_rel"] == pytest.approx(expected.cameras[0].fx / cfg.rig.cameras[0].fx - 1, rel=1e-9)


@pytest.mark.slow
def test_sensor_view_hides_the_true_calibration(pair):
    from vo.dataset.open import open_dataset
    from vo.estimators.sensor_view import SensorView
    _, out = pair
    with SensorView(open_dataset(out["bad"])) as view:
        names = {p.name for p in view.rglob("*")}
    assert "rig.yaml" in names and not names & {"rig_true.yaml", "sensor_effects.yaml", "frame_effects.csv"}
    assert "imu.yaml" in names and "camchain-imucam.yaml" not in names    # its timeshift_cam_imu is truth


def test_fisheye_coefficients_take_the_first_four_draws():
    rig = get_rig("fisheye150")
    z = np.random.default_rng(5).standard_normal((len(rig.cameras), 15))
    bad, _ = perturb_rig(rig, ERR, np.random.default_rng(5))
    for c, p, zk in zip(rig.cameras, bad.cameras, z):
        assert p.dist_model == "equidistant"
        assert np.allclose(np.array(p.dist), np.array(c.dist) * (1 + ERR.dist_rel * zk[4:8]), atol=0)
