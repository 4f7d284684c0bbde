"""Sensor effects off (the default) change nothing: configuration, hash, files, and the noise step."""
import hashlib

import numpy as np
import pytest

from rigs.model import Camera, Rig
from sim.generate_config import CameraEffects, GenerateConfig
from sim.rng import indexed_stream
from sim.sensors.camera import FrameExposer, add_noise

OFF = ["camera.exposure_ms=0", "camera.line_delay_us=0", "camera.vignetting=0", "camera.auto_exposure=false",
       "camera.read_noise_dn=0", "camera.shot_noise_gain=0", "camera.timestamp_jitter_us=0",
       "imu.time_offset_ms=0", "calib_error.focal_ppm=0", "calib_error.extrinsic_rot_deg=0"]


def test_effect_pieces_off_leave_the_configuration_and_hash_alone():
    base = GenerateConfig()
    off = base.with_overrides(OFF)
    assert not {"camera", "imu_clock", "calib_error"} & set(base.to_dict())
    assert off.to_dict() == base.to_dict() and off.config_hash() == base.config_hash()
    on = base.with_overrides(["camera.exposure_ms=4"])
    assert on.to_dict()["camera"]["exposure_ms"] == 4.0 and on.config_hash() != base.config_hash()


class TexturedCamera:
    def measure(self, T_w_b, dynamic_state=None):
        rng = np.random.default_rng(int(T_w_b[0, 3] * 1000) % 7)
        return [rng.integers(0, 256, (24, 32), dtype=np.uint8) for _ in range(2)], None, None


def test_exposer_without_image_effects_equals_the_plain_noise_step():
    """The exposer's quantise-then-noise path is the one of frames without effects, byte for byte."""
    rig = Rig("r", (Camera("a", 32, 24, 20, 20, 16, 12), Camera("b", 32, 24, 20, 20, 16, 12)))
    ex = FrameExposer(TexturedCamera(), rig, CameraEffects(), 0.1, seed=5, image_sigma=1.5)
    pose_at = lambda t: np.tile(np.eye(4), (len(t), 1, 1))  # noqa: E731
    for k in range(3):
        got = ex.expose(k, k * 100_000_000, pose_at, lambda t: None)[0]
        clean = TexturedCamera().measure(np.eye(4))[0]
        want = add_noise(clean, 1.5, indexed_stream(5, "image_noise", k))
        assert all(np.array_equal(a, b) for a, b in zip(got, want))


def _digest(folder):
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(folder)).encode() + p.read_bytes())
    return h.hexdigest()


@pytest.mark.slow
def test_dataset_with_effects_off_is_byte_identical(tmp_path):
    """One short dataset (smoke, 0.3 s): the default and every effect knob set to off give the same bytes,
    and no effect truth file is written."""
    from sim.generate import generate
    from sim.scenarios import get_scenario
    base = get_scenario("smoke").with_value("duration_s", 0.3)
    generate(base, tmp_path / "a", progress=False)
    generate(base.with_overrides(OFF), tmp_path / "b", progress=False)
    assert _digest(tmp_path / "a") == _digest(tmp_path / "b")
    assert not {"rig_true.yaml", "sensor_effects.yaml", "frame_effects.csv"} & {p.name for p in (tmp_path / "a").iterdir()}
