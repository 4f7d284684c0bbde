"""Exact IMU: MuJoCo sensors vs the analytic formula, static case, dead reckoning over 60 s."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from rigs.model import Imu
from scenes.base import Route
from sim.errors import SimError
from sim.sensors.imu import (G_W, analytic_imu, imu_pose_velocity, imu_times_ns, integrate_imu, measure, measure_imu,
                     measure_states)
from sim.rng import stream
from sim.motion import MotionConfig, VehicleTrajectory
from rigs.geometry import R_from_opk_deg, make_T, so3_log

LOOP = Route(((0, 0), (6, -1), (10, 0), (11, 4), (6, 6), (0, 5), (-2, 2)), closed=True,
             cruise_speed_mps=0.5, accel_mps2=0.4)          # ~33 m, ~70 s per lap
IMU = Imu(T_b_i=make_T(R_from_opk_deg(10, -20, 95), [0.3, -0.2, 0.8]), rate_hz=200.0)


def hills(x, y):
    return 0.2 * np.sin(0.3 * x) + 0.1 * np.cos(0.4 * y) + 0.02 * x


@pytest.fixture(scope="module")
def traj():
    return VehicleTrajectory.from_route(LOOP, hills, MotionConfig(), stream(7, "motion"), duration_s=60.0)


def test_imu_times_are_exact_integers():
    t = imu_times_ns(1_000_000_000, 61_000_000_000, 200.0)
    assert t.dtype == np.int64 and t[0] == 1_000_000_000 and t[-1] == 61_000_000_000
    assert np.all(np.diff(t) == 5_000_000) and t.size == 12001
    t3 = imu_times_ns(0, 10**9, 300.0)                      # 1e9/300 is not an integer
    assert np.abs(t3 - np.arange(301) * 1e9 / 300).max() <= 0.5
    with pytest.raises(SimError, match="rate_hz"):
        imu_times_ns(0, 10, 0.0)


def test_mujoco_sensors_match_analytic_formula(traj):
    """mj_inverse accelerometer/gyro vs R_i_w (a_w + alpha x r + omega x (omega x r) - g), R_i_b omega.
    Both are O(10) flops of float64 on O(10) m/s^2 values: agreement to 1e-9 (measured ~1e-14)."""
    t = np.linspace(traj.t0_ns, traj.t1_ns, 400).astype(np.int64)
    st = traj.states(t)
    mj, an = measure(st, IMU), analytic_imu(st, IMU.T_b_i_array)      # the IMU sensor's clean step
    assert np.abs(mj.gyro - an.gyro).max() < 1e-9
    assert np.abs(mj.accel - an.accel).max() < 1e-9
    # the lever-arm terms matter: without them the accelerometers would differ by > 1e-4
    st0 = traj.states(t)
    no_lever = analytic_imu(st0, make_T(IMU.T_b_i_array[:3, :3], np.zeros(3)))
    assert np.abs(no_lever.accel - an.accel).max() > 1e-4


def test_static_imu_reads_minus_gravity():
    """At rest (t0): accel = R_i_w (0,0,+9.81), gyro = 0."""
    tr = VehicleTrajectory.from_route(LOOP, hills, MotionConfig(), stream(7, "motion"))
    s = measure_imu(tr, IMU, np.array([tr.t0_ns, tr.t1_ns]))
    R_w_i = tr.states(np.array([tr.t0_ns, tr.t1_ns])).T_w_b[:, :3, :3] @ IMU.T_b_i_array[:3, :3]
    expected = np.einsum("nji,j->ni", R_w_i, -G_W)
    assert np.abs(s.accel - expected).max() < 1e-12 and np.abs(s.gyro).max() < 1e-12


def test_integrating_ideal_imu_recovers_truth(traj):
    """60 s, ~28 m of a hilly loop with vibration, IMU 0.9 m from b and rotated, 200 Hz exact samples,
    RK4 with 6-point midpoint interpolation from the true initial IMU state.
    Measured: end position error 7.5e-8 m, attitude error 1.1e-9 deg (limits: 1 cm, 0.01 deg)."""
    t = imu_times_ns(traj.t0_ns, traj.t1_ns, IMU.rate_hz)
    st = traj.states(t)
    T_w_i, v_w_i = imu_pose_velocity(st, IMU.T_b_i_array)
    T_est, v_est = integrate_imu(measure_states(st, IMU.T_b_i_array), T_w_i[0], v_w_i[0])
    pos_err = np.linalg.norm(T_est[-1, :3, 3] - T_w_i[-1, :3, 3])
    att_err = np.degrees(np.linalg.norm(so3_log(T_est[-1, :3, :3].T @ T_w_i[-1, :3, :3])))
    print(f"pos_err {pos_err:.3g} m, att_err {att_err:.3g} deg")
    assert pos_err < 0.01 and att_err < 0.01
    assert np.abs(v_est - v_w_i).max() < 1e-3
    assert traj.path_length() > 25.0                          # the vehicle really drove


def test_integrator_requires_uniform_samples(traj):
    t = np.array([traj.t0_ns, traj.t0_ns + 5_000_000, traj.t0_ns + 11_000_000])
    s = measure_imu(traj, IMU, t)
    with pytest.raises(SimError, match="uniformly"):
        integrate_imu(s, np.eye(4), np.zeros(3))
