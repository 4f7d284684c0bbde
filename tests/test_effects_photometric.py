"""Photometric effects: shot + read noise statistics, vignetting fall-off, auto exposure dynamics."""
import numpy as np
import pytest

from rigs.model import Camera, Rig
from sim.generate_config import CameraEffects
from sim.sensors.camera import FrameExposer
from sim.sensors.photometric import AutoExposure, noise_variance, sensor_noise, vignetting_map


@pytest.mark.parametrize("read_dn,gain", [(1.2, 0.03), (0.0, 0.2), (2.0, 0.0)])
def test_shot_read_noise_variance_follows_the_model(read_dn, gain):
    rng = np.random.default_rng(4)
    for level in (12.0, 60.0, 130.0, 210.0):
        flat = np.full((500, 500), level)
        out = sensor_noise(flat, read_dn, gain, rng).astype(float)
        predicted = noise_variance(level, read_dn, gain) + 1.0 / 12.0     # + rounding to integers
        # 250000 samples: the sample variance has a relative std of sqrt(2/n) = 0.3 %; 3 % allows the
        # rounding term being only approximately 1/12 for a discrete (Poisson) signal
        assert out.var() == pytest.approx(predicted, rel=0.03)
        assert out.mean() == pytest.approx(level, abs=0.02 + 3 * np.sqrt(predicted / out.size))


def test_noise_grows_with_signal():
    """Shot noise: the variance at 200 grey levels exceeds that at 20 by K x 180."""
    rng = np.random.default_rng(0)
    v = [sensor_noise(np.full((400, 400), s), 1.0, 0.05, rng).astype(float).var() for s in (20.0, 200.0)]
    assert v[1] - v[0] == pytest.approx(0.05 * 180, rel=0.05)


def test_vignetting_is_cos4_of_the_ray_angle():
    cam = Camera("c", 64, 48, 40.0, 42.0, 31.0, 23.5)
    m = vignetting_map(cam, 1.0)
    v, u = np.mgrid[0:48, 0:64]
    rays = np.linalg.inv(cam.K) @ np.stack([u.ravel(), v.ravel(), np.ones(u.size)])
    cos_theta = rays[2] / np.linalg.norm(rays, axis=0)
    assert np.allclose(m.ravel(), cos_theta ** 4, atol=1e-6)
    half = vignetting_map(cam, 0.5)
    assert np.allclose(half, 0.5 + 0.5 * m, atol=1e-6)


class FlatCamera:
    def __init__(self, level):
        self.level = level

    def measure(self, T_w_b, dynamic_state=None):
        img = np.full((20, 30), self.level, np.uint8)
        return [img, img.copy()], None, None


def test_auto_exposure_converges_with_its_time_constant():
    """A scene of constant brightness 50: the output mean approaches 0.45 x 255 with the gain's error
    shrinking by exp(-dt / tau) per frame (from gain 1 at frame 0, the gain lagging one frame)."""
    tau, dt = 0.3, 0.05
    rig = Rig("flat", (Camera("a", 30, 20, 20, 20, 15, 10), Camera("b", 30, 20, 20, 20, 15, 10)))
    ex = FrameExposer(FlatCamera(50), rig, CameraEffects(auto_exposure=True, ae_time_constant_s=tau), dt, 0, 0.0,
                      noisy=False)
    gains = [ex.expose(k, k * 50_000_000, lambda t: np.tile(np.eye(4), (len(t), 1, 1)), lambda t: None)[3]
             for k in range(30)]
    target = 0.45 * 255 / 50
    err = target - np.array(gains)
    k = int(round(tau / dt))
    assert gains[0] == 1.0
    assert err[1 + k] / err[1] == pytest.approx(np.exp(-1.0), rel=1e-6)
    assert gains[-1] == pytest.approx(target, rel=0.01)
    ae = AutoExposure(0.45, tau, dt)
    ae.update(5.0)                     # a very dark frame: the gain is capped at 4
    for _ in range(100):
        ae.update(5.0)
    assert ae.gain == 4.0
