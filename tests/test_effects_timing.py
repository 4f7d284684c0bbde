"""Motion blur and rolling shutter through :class:`sim.sensors.camera.FrameExposer`.

The camera is an analytic stand-in for the renderer (an area-sampled vertical step edge seen by a
pinhole camera; its image position follows the pose exactly), so the prediction is exact: blur length =
image speed x exposure, skew = image speed x readout time. The exposer, the exposure plan and the
assembly are the code the simulator runs."""
import numpy as np
import pytest

from rigs.model import Camera, Rig
from sim.generate_config import CameraEffects
from sim.sensors.camera import FrameExposer
from sim.sensors.effects_timing import exposure_plan

W, H, F = 160, 120, 200.0
LO, HI = 40.0, 200.0


def _rig():
    cam = Camera("cam0", W, H, F, F, (W - 1) / 2, (H - 1) / 2)
    return Rig("edge", (cam, Camera("cam1", W, H, F, F, (W - 1) / 2, (H - 1) / 2)))


class EdgeCamera:
    """Bright right of a vertical world line at x_w = 0, z_w = 2 m ahead; the camera at (x, 0, 0) yawed by
    ``yaw`` about its y axis: the edge column is ``cx + f tan(atan2(-x, 2) - yaw)``. Each pixel is the
    exact area average (the edge is a vertical line, so only the column matters)."""

    def measure(self, T_w_b, dynamic_state=None):
        x = T_w_b[0, 3]
        yaw = np.arctan2(T_w_b[0, 2], T_w_b[2, 2])
        u_edge = (W - 1) / 2 + F * np.tan(np.arctan2(-x, 2.0) - yaw)
        left = np.arange(W) - 0.5
        frac_bright = np.clip(left + 1.0 - u_edge, 0.0, 1.0)          # part of the pixel right of the edge
        row = LO + (HI - LO) * frac_bright
        img = np.rint(np.tile(row, (H, 1))).astype(np.uint8)
        return [img, img.copy()], None, None


def _pose_translating(v_mps):
    def pose_at(t_ns):
        T = np.tile(np.eye(4), (len(t_ns), 1, 1))
        T[:, 0, 3] = v_mps * np.asarray(t_ns, float) * 1e-9
        return T
    return pose_at


def _pose_yawing(omega):
    def pose_at(t_ns):
        a = omega * np.asarray(t_ns, float) * 1e-9
        T = np.tile(np.eye(4), (len(t_ns), 1, 1))
        T[:, 0, 0], T[:, 0, 2], T[:, 2, 0], T[:, 2, 2] = np.cos(a), np.sin(a), -np.sin(a), np.cos(a)
        return T
    return pose_at


def _expose(effects, pose_at, t_ns=0):
    ex = FrameExposer(EdgeCamera(), _rig(), effects, period_s=0.05, seed=0, image_sigma=0.0, noisy=False)
    images, _, _, _ = ex.expose(0, t_ns, pose_at, lambda t: None)
    return images[0].astype(float)


def _edge_positions(img):
    """Per row: the edge column from the bright area (the first moment of the step's derivative)."""
    frac = (img - LO) / (HI - LO)
    return W - 0.5 - frac.sum(axis=1)


def _blur_length(img):
    """Length of the box the edge was smeared over: from the variance of the row profile's derivative,
    minus the 1/12 px^2 of pixel-area sampling (a box of length L has variance L^2 / 12)."""
    d = np.diff((img[H // 2] - LO) / (HI - LO))
    x = np.arange(len(d)) + 0.5
    d = d / d.sum()
    var = (d * x ** 2).sum() - (d * x).sum() ** 2
    return np.sqrt(12.0 * max(var - 1.0 / 12.0, 0.0))


@pytest.mark.parametrize("exposure_ms,subframes", [(10.0, 5), (20.0, 9)])
def test_blur_length_is_image_speed_times_exposure(exposure_ms, subframes):
    v = 10.0                                                        # m/s sideways, 2 m from the edge
    effects = CameraEffects(exposure_ms=exposure_ms, blur_subframes=subframes)
    img = _expose(effects, _pose_translating(v))
    speed_px = F * v / 2.0                                          # d(u)/dt at x = 0: f v / Z
    predicted = speed_px * exposure_ms * 1e-3
    assert predicted > 8                                            # a blur far above the pixel size
    # tolerance: 10 %; S equal sub-frames give a box variance of L^2/12 (1 - 1/S^2), 2 % low at S = 5
    assert _blur_length(img) == pytest.approx(predicted, rel=0.10)
    # the mid-exposure time is the frame time: the blurred edge is centred on the sharp edge at t
    sharp = _expose(CameraEffects(), _pose_translating(v))
    assert _edge_positions(img).mean() == pytest.approx(_edge_positions(sharp).mean(), abs=0.05)


@pytest.mark.parametrize("line_delay_us,omega", [(30.0, 8.0), (60.0, -4.0)])
def test_rolling_shutter_skew_is_image_speed_times_readout(line_delay_us, omega):
    effects = CameraEffects(line_delay_us=line_delay_us, rs_poses=5)
    img = _expose(effects, _pose_yawing(omega))
    u = _edge_positions(img)
    readout_s = (H - 1) * line_delay_us * 1e-6
    predicted = -F * omega * readout_s             # edge at the image centre: du/dt = -f omega
    skew = np.polyfit(np.arange(H), u, 1)[0] * (H - 1)
    assert abs(predicted) > 5
    assert skew == pytest.approx(predicted, rel=0.10)
    # the centre row is exposed at the frame time: it matches the global-shutter edge there
    sharp = _edge_positions(_expose(CameraEffects(), _pose_yawing(omega)))
    assert np.interp((H - 1) / 2, np.arange(H), u) == pytest.approx(sharp.mean(), abs=0.05)


def test_plan_weights_cover_each_rows_exposure():
    """Every row's weights sum to 1, and its weighted render time is the row's mid-exposure time up to the
    midpoint rule's quantisation: the two partly covered cells (width c) shift it by at most c^2 / (4 E)."""
    E = 8e-3
    plan = exposure_plan(E * 1e3, 40.0, 100, blur_subframes=5, rs_poses=5)
    cell = np.diff(plan.offsets_ns).mean() * 1e-9
    assert np.allclose(plan.weights.sum(axis=1), 1.0)
    assert plan.offsets_ns[plan.centre] == 0 and len(plan.offsets_ns) % 2 == 1
    t_row = plan.weights @ plan.offsets_ns.astype(float)
    expected = (np.arange(100) - 49.5) * 40e3
    assert np.abs(t_row - expected).max() <= cell ** 2 / (4 * E) * 1e9 + 1.0    # + 1 ns of rounding


def test_reported_blur_length_of_a_sideways_translation():
    """Camera translating sideways at v: every point at depth Z moves f v E / Z px; points at infinity not at all."""
    from sim.sensors.effects_timing import blur_lengths_px
    cam = _rig().cameras[0]
    v, E = 1.5, 0.004
    T = np.tile(np.eye(4), (3, 2, 1, 1))
    T[0, :, 0, 3], T[1, :, 0, 3] = -v * E / 2, v * E / 2
    near, far = blur_lengths_px(T[0], T[1], T[2], cam, depth_m=5.0)
    assert np.allclose(near, F * v * E / 5.0, rtol=1e-9) and np.allclose(far, 0.0, atol=1e-9)
