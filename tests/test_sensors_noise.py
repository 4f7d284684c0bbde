"""Sensors' noise steps (a fixed seed gives the same bytes twice; zero noise is the identity and draws
nothing), the IMU's clean step against the analytic truth, and the one seeding module (sim.rng)."""
import zlib

import numpy as np
import pytest

from rigs.model import Imu
from scenes.base import Route
from sim.errors import SimError
from sim.motion import MotionConfig, VehicleTrajectory
from sim.rng import indexed_stream, scene_streams, stream
from sim.sensors import camera, wheels
from sim.sensors.imu import analytic_imu, measure
from sim.sensors.imu_noise import add_imu_noise
from sim.vehicles import CART

ROUTE = Route(((0, 0), (8, 0), (10, 3)), cruise_speed_mps=1.0)


def _flat(x, y):
    return np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)


@pytest.fixture(scope="module")
def traj():
    return VehicleTrajectory.from_route(ROUTE, _flat, MotionConfig(), stream(0, "motion"))


def _state(rng):
    return rng.bit_generator.state["state"]["state"]


def test_camera_noise_step():
    imgs = [np.random.default_rng(1).integers(0, 256, (40, 60), dtype=np.uint8) for _ in range(2)]
    a = camera.add_noise(imgs, 2.0, indexed_stream(0, "image_noise", 5))
    b = camera.add_noise(imgs, 2.0, indexed_stream(0, "image_noise", 5))
    assert all(x.tobytes() == y.tobytes() for x, y in zip(a, b))
    assert not np.array_equal(a[0], imgs[0]) and not np.array_equal(a[1], imgs[1])
    rng = indexed_stream(0, "image_noise", 5)
    before = _state(rng)
    same = camera.add_noise(imgs, 0.0, rng)
    assert all(np.array_equal(x, y) for x, y in zip(same, imgs)) and _state(rng) == before


def test_wheel_slip_noise_step(traj):
    t = np.arange(traj.t0_ns, traj.t1_ns + 1, 20_000_000, dtype=np.int64)
    clean = wheels.measure(traj, CART, t)
    a = wheels.add_slip_noise(clean, 0.05, stream(3, "wheels"))
    b = wheels.add_slip_noise(clean, 0.05, stream(3, "wheels"))
    assert a.dist_m.tobytes() == b.dist_m.tobytes() and not np.array_equal(a.dist_m, clean.dist_m)
    assert np.array_equal(wheels.add_slip_noise(clean, 0.0, stream(3, "wheels")).dist_m, clean.dist_m)
    # clean travel: both wheels roll the route's length (the turn is left: the right wheel rolls more)
    total = clean.dist_m.sum(0)
    assert total.mean() == pytest.approx(traj.route_length_m, rel=1e-3) and total[1] > total[0]


def test_imu_noise_step_identity_at_zero_noise(traj):
    t = np.arange(traj.t0_ns, traj.t0_ns + 2 * 10**9, 5_000_000, dtype=np.int64)
    clean = measure(traj.states(t), Imu())
    out, bias = add_imu_noise(clean, Imu(), stream(0, "imu_white"), stream(0, "imu_bias"))
    assert out.gyro.tobytes() == clean.gyro.tobytes() and out.accel.tobytes() == clean.accel.tobytes()
    assert not np.any(bias.b_g) and not np.any(bias.b_a)


def test_imu_clean_step_is_the_analytic_truth(traj):
    """mj_inverse vs the closed form on O(10) m/s^2 values in float64: 1e-9 (measured ~1e-14)."""
    imu = Imu(T_b_i=((0, -1, 0, 0.1), (1, 0, 0, -0.05), (0, 0, 1, 0.9), (0, 0, 0, 1)))
    st = traj.states(np.linspace(traj.t0_ns, traj.t1_ns, 200).astype(np.int64))
    mj, an = measure(st, imu), analytic_imu(st, imu.T_b_i_array)
    assert np.abs(mj.gyro - an.gyro).max() < 1e-9 and np.abs(mj.accel - an.accel).max() < 1e-9


def test_streams_are_one_scheme_and_unknown_names_are_sim_errors():
    want = np.random.default_rng(np.random.SeedSequence([4, zlib.crc32(b"wheels")])).random(3)
    assert np.array_equal(stream(4, "wheels").random(3), want)
    key = np.random.default_rng(np.random.SeedSequence([4, zlib.crc32(b"campus/museum")])).random(3)
    assert np.array_equal(scene_streams(4)("campus/museum").random(3), key)
    with pytest.raises(SimError, match="random stream 'imu'.*valid: motion"):
        stream(0, "imu")
    with pytest.raises(SimError, match="scene stream key 'museum'"):
        scene_streams(0)("museum")
