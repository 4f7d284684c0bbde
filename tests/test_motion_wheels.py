"""Wheel encoders on a differential-drive vehicle: distance, turning ratio, slip noise seeding."""
import numpy as np
import pytest

from rigs.model import Wheels
from scenes.base import Route
from sim.rng import stream
from sim.motion import MotionConfig, VehicleTrajectory
from sim.sensors.wheels import measure_wheels
from sim.vehicles import VehicleDims

STILL = MotionConfig(vibration_pitch_deg=0, vibration_roll_deg=0, vibration_yaw_deg=0, vibration_heave_m=0)
WHEELS = Wheels(rate_hz=50.0, ticks_per_rev=1024)
DIMS = VehicleDims(track_m=0.5, wheelbase_m=0.6, wheel_radius_m=0.1)


def flat(x, y):
    return np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)


def times(tr, rate):
    return np.arange(tr.t0_ns, tr.t1_ns + 1, int(1e9 / rate), dtype=np.int64)


def test_straight_line_ticks_equal_distance():
    """20 m straight: each wheel turns 20 / (2 pi 0.1) rev; GL-5 per 20 ms interval is exact to ~1e-12."""
    tr = VehicleTrajectory.from_route(Route(((0, 0), (20, 0))), flat, STILL, stream(0, "motion"))
    w = measure_wheels(tr, DIMS, WHEELS, times(tr, 50.0), stream(0, "wheels"))
    expected = int(np.floor(20.0 / (2 * np.pi * 0.1) * 1024))
    assert w.left_ticks[-1] == expected and w.right_ticks[-1] == expected
    assert w.left_ticks[0] == 0 and np.all(np.diff(w.left_ticks) >= 0)


def test_circle_left_right_ratio():
    """Counter-clockwise circle of radius 5 m: right/left distance = (R + T/2) / (R - T/2) to the
    tick quantisation (1 tick in ~1.6e4) plus the spline's deviation from the circle (< 1e-4)."""
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    tr = VehicleTrajectory.from_route(Route(tuple(zip(5 * np.cos(a), 5 * np.sin(a))), closed=True),
                                      flat, STILL, stream(0, "motion"))
    w = measure_wheels(tr, DIMS, WHEELS, times(tr, 50.0), stream(0, "wheels"))
    assert w.right_ticks[-1] / w.left_ticks[-1] == pytest.approx(5.25 / 4.75, rel=2e-4)


def test_slip_noise_is_seeded():
    tr = VehicleTrajectory.from_route(Route(((0, 0), (20, 0))), flat, STILL, stream(0, "motion"))
    slippy = Wheels(slip_std=0.05)
    t = times(tr, 50.0)
    a, b, c = (measure_wheels(tr, DIMS, slippy, t, stream(s, "wheels")) for s in (1, 1, 2))
    assert np.array_equal(a.left_ticks, b.left_ticks) and not np.array_equal(a.left_ticks, c.left_ticks)
    # per-interval relative error 5 % over ~800 moving intervals averages to ~0.2 %: total within 2 %
    assert a.left_ticks[-1] == pytest.approx(20.0 / (2 * np.pi * 0.1) * 1024, rel=0.02)
