"""Motion blur on real renders: the camera yaws in the indoor (smoke) scene at omega; pure rotation moves
every pixel near the image centre by f omega per second (no parallax), so the blurred frame is the sharp
frame smeared horizontally over f omega E pixels."""
import numpy as np
import pytest

from sim.generate_config import CameraEffects
from sim.generate import resolve
from sim.scenarios import get_scenario
from sim.sensors.camera import FrameExposer, StereoCamera


def _smear(rows: np.ndarray, length: float) -> np.ndarray:
    """Horizontal box filter of ``length`` px (fractional end taps) along each row."""
    n = int(np.ceil(length / 2.0 - 0.5))
    x = np.arange(-n, n + 1)
    k = np.clip(np.minimum(x + 0.5, length / 2.0) - np.maximum(x - 0.5, -length / 2.0), 0.0, None)
    k /= k.sum()
    return np.stack([np.convolve(r, k, mode="same") for r in rows])


@pytest.mark.slow
def test_rendered_blur_length_is_f_omega_exposure():
    cfg = get_scenario("smoke")
    setup = resolve(cfg)
    cam = setup.rig.cameras[0]                         # stereo27: pinhole, f = 458 px
    exposure_ms, omega = 10.0, 2.5                     # 11.5 px of blur
    T0 = setup.trajectory.states(np.array([setup.frame_t_ns[0]])).T_w_b[0]

    def pose_at(t_ns):
        a = omega * np.asarray(t_ns, float) * 1e-9
        Rz = np.tile(np.eye(4), (len(a), 1, 1))
        Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a)
        return T0 @ Rz                                   # yaw about the body's up axis, position fixed

    with StereoCamera(setup.scene, setup.rig, vehicle=cfg.vehicle) as camera:
        def frame(effects):
            ex = FrameExposer(camera, setup.rig, effects, 0.05, 0, 0.0, noisy=False)
            return ex.expose(0, 0, pose_at, setup.scene.actor_states)[0][0].astype(float)
        sharp = frame(CameraEffects())
        blurred = frame(CameraEffects(exposure_ms=exposure_ms, blur_subframes=9))
    predicted = cam.fx * omega * exposure_ms * 1e-3
    c0, half = int(cam.cx), int(0.15 * cam.fx)          # |u - cx| < 0.15 f: speed within 2.3 % of f omega
    rows = slice(int(cam.cy) - 100, int(cam.cy) + 100)
    s, b = sharp[rows, c0 - half - 20:c0 + half + 20], blurred[rows, c0 - half - 20:c0 + half + 20]
    assert np.abs(np.diff(s, axis=1)).mean() > 2.0       # textured enough to measure a smear
    lengths = np.arange(1.0, 2.0 * predicted, 0.1)
    sse = [((_smear(s, L) - b)[:, 20:-20] ** 2).mean() for L in lengths]
    measured = lengths[int(np.argmin(sse))]
    # 10 %: the speed varies by 2.3 % over the window, 9 sub-frames sample the smear in 1.3 px steps
    assert measured == pytest.approx(predicted, rel=0.10)
