"""Dead-reckoning EKF (sim.sensors.deadreckoning) on the simulator's cart motion over hilly ground: with exact
IMU and wheel ticks it tracks the truth closely; with gyro noise and wheel slip its covariance is
consistent with its error (position NEES over seeds); with an accelerometer bias on a stop-and-go drive
its vertical covariance holds the height error that the biased tilt makes."""
import dataclasses

import numpy as np
import pytest
from scipy.stats import chi2

from rigs.geometry import make_T
from rigs.model import Imu
from scenes.base import Route
from sim.motion import MotionConfig, VehicleTrajectory
from sim.rng import stream
from sim.sensors.imu import imu_times_ns, measure_imu
from sim.sensors.imu_noise import add_imu_noise
from sim.sensors.wheels import WheelTravel, add_slip_noise, encoder_ticks, measure
from sim.vehicles import CART
from sim.sensors.deadreckoning import DeadReckoningConfig, dead_reckon
from sim.errors import SimError

ROUTE = Route(((0, 0), (8, -1), (12, 2), (9, 7), (3, 6)), closed=False, cruise_speed_mps=0.5, accel_mps2=0.4)
IMU = Imu(rate_hz=100.0, gyro_noise_density=2e-3)      # noisy gyro (rad/s/sqrt(Hz)), ~15x a MEMS IMU


def hills(x, y):
    return 0.2 * np.sin(0.3 * x) + 0.1 * np.cos(0.4 * y)


@pytest.fixture(scope="module")
def traj():
    return VehicleTrajectory.from_route(ROUTE, hills, MotionConfig(), stream(3, "motion"), duration_s=40.0)


def run(traj, seed, slip, gyro_noise, slip_bias=0.0, bias_std=0.0):
    t = imu_times_ns(traj.t0_ns, traj.t1_ns, IMU.rate_hz)
    imu = measure_imu(traj, IMU, t)
    if gyro_noise:
        imu, _ = add_imu_noise(imu, IMU, stream(seed, "imu_white"), stream(seed, "imu_bias"))
    travel = measure(traj, CART, t[::2])
    if slip:
        travel = add_slip_noise(travel, slip, np.random.default_rng(seed))
    travel = WheelTravel(travel.t_ns, travel.dist_m / (1.0 - slip_bias))     # the wheels turn more than travelled
    wheels = encoder_ticks(travel, CART.wheel_radius_m, 4096)
    truth = traj.states(t).T_w_b
    cfg = DeadReckoningConfig(CART.wheel_radius_m, 4096, gyro_noise_density=IMU.gyro_noise_density if gyro_noise
                              else 1e-6, slip_std=max(slip, 1e-4), slip_bias_std=bias_std, slip_bias_walk=0.0)
    dr = dead_reckon(imu, wheels, np.eye(3), truth[0], np.diag([1e-8] * 3 + [1e-8] * 3), cfg)
    path = np.sum(np.linalg.norm(np.diff(truth[:, :3, 3], axis=0), axis=1))
    return dr, truth, path


def test_exact_imu_and_wheels_track_the_truth(traj):
    """Exact gyro, 4096-tick encoders: the only errors are the 0.1 mm tick quantum, the body's
    vibration (wheels measure the forward speed of the body origin exactly) and the O(dt^2) midpoint
    integration: < 0.2 % of the distance."""
    dr, truth, path = run(traj, 0, 0.0, False)
    err = np.linalg.norm(dr.T_w_b[:, :3, 3] - truth[:, :3, 3], axis=1)
    assert path > 15 and err.max() < 2e-3 * path, (err.max(), path)
    dyaw = np.arctan2(dr.T_w_b[-1, 1, 0], dr.T_w_b[-1, 0, 0]) - np.arctan2(truth[-1, 1, 0], truth[-1, 0, 0])
    assert abs(dyaw) < 1e-3


@pytest.mark.long       # Monte-Carlo over a whole route: 1-2 min each on 2 cores
def test_noisy_covariance_is_consistent_with_the_error(traj):
    """Gyro white noise + 5 % wheel slip, 8 seeds: mean final-position NEES (3 dof, horizontal
    and vertical) inside the 99.9 % interval of chi2(24)/8; the error is not negligible (> 0.2 % of distance)."""
    nees, rel = [], []
    for seed in range(8):
        dr, truth, path = run(traj, seed, 0.05, True)
        e = dr.T_w_b[-1, :3, :3].T @ (truth[-1, :3, 3] - dr.T_w_b[-1, :3, 3])     # body-frame error
        nees.append(e @ np.linalg.solve(dr.cov[-1][3:, 3:], e))
        rel.append(np.linalg.norm(e) / path)
    lo, hi = chi2.ppf([0.0005, 0.9995], 24) / 8
    assert lo < np.mean(nees) < hi, (np.mean(nees), lo, hi)
    assert np.mean(rel) > 0.002


@pytest.mark.long       # Monte-Carlo over a whole route: 1-2 min each on 2 cores
def test_common_slip_bias_is_in_the_covariance(traj):
    """A common slip drawn per seed from N(0, 0.1^2) (the filter's slip-bias prior) on top of 5 %
    white slip and gyro noise, 8 seeds: mean final-position NEES inside the 99.9 % interval of
    chi2(24)/8; the error is several % of the distance (the bias is not observable)."""
    nees, rel = [], []
    for seed in range(8):
        b = 0.1 * np.random.default_rng(100 + seed).standard_normal()
        dr, truth, path = run(traj, seed, 0.05, True, slip_bias=b, bias_std=0.1)
        e = dr.T_w_b[-1, :3, :3].T @ (truth[-1, :3, 3] - dr.T_w_b[-1, :3, 3])
        nees.append(e @ np.linalg.solve(dr.cov[-1][3:, 3:], e))
        rel.append(np.linalg.norm(e) / path)
    lo, hi = chi2.ppf([0.0005, 0.9995], 24) / 8
    assert lo < np.mean(nees) < hi, (np.mean(nees), lo, hi)
    assert np.mean(rel) > 0.02


STOP_ROUTE = dataclasses.replace(ROUTE, stops_m=(6.0, 12.0, 18.0), stop_dwell_s=5.0)
IMU_BIASED = Imu(rate_hz=20.0, gyro_noise_density=2e-3, accel_noise_density=2e-3, accel_random_walk=0.005)
ACCEL_BIAS0 = 0.1       # m/s^2, initial accelerometer bias 1-sigma: 0.6 deg of tilt


@pytest.fixture(scope="module")
def stop_and_go():
    motion = MotionConfig(rest_before_s=5.0, rest_after_s=2.0, start_speed_mps=0.0)
    return VehicleTrajectory.from_route(STOP_ROUTE, hills, motion, stream(3, "motion"))


def biased_run(traj, seed, bias_model: bool) -> tuple:
    """Stop-and-go drive, IMU with an initial accelerometer bias (N(0, ACCEL_BIAS0^2) per axis) and its
    random walk, 5 % white slip. ``bias_model``: the filter's accelerometer-bias states and the
    moving/static tilt sigmas; else the filter without them (one tilt sigma of 0.02 rad, no bias).
    -> (vertical NEES (1 dof, world z), position NEES (3 dof), world z error m)."""
    t = imu_times_ns(traj.t0_ns, traj.t1_ns, IMU_BIASED.rate_hz)
    imu, _ = add_imu_noise(measure_imu(traj, IMU_BIASED, t), IMU_BIASED, stream(seed, "imu_white"),
                           stream(seed, "imu_bias"), initial_accel_bias_std=ACCEL_BIAS0)
    wheels = encoder_ticks(add_slip_noise(measure(traj, CART, t), 0.05, np.random.default_rng(seed)),
                           CART.wheel_radius_m, 4096)
    truth = traj.states(t).T_w_b
    extra = dict(accel_bias_std=ACCEL_BIAS0, accel_bias_walk=IMU_BIASED.accel_random_walk) if bias_model else \
        dict(tilt_sigma_rad=0.02, tilt_sigma_moving_rad=0.02)
    cfg = DeadReckoningConfig(CART.wheel_radius_m, 4096, gyro_noise_density=IMU_BIASED.gyro_noise_density,
                              slip_std=0.05, slip_bias_std=0.0, slip_bias_walk=0.0, **extra)
    dr = dead_reckon(imu, wheels, np.eye(3), truth[0], np.diag([1e-8] * 6), cfg)
    e = truth[-1, :3, 3] - dr.T_w_b[-1, :3, 3]
    R = dr.T_w_b[-1, :3, :3]
    C_w = R @ dr.cov[-1][3:, 3:] @ R.T
    return e[2] ** 2 / C_w[2, 2], e @ np.linalg.solve(C_w, e), e[2]


@pytest.mark.long       # Monte-Carlo over a whole route: 1-2 min each on 2 cores
def test_vertical_covariance_holds_the_accelerometer_bias(stop_and_go):
    """The height error is the pitch error integrated over the distance, and a tilt measured by the
    accelerometer carries its bias (b_a / g: 0.6 deg here), which averaging the static updates does
    not remove. 6 seeds, 20 m with three stops: with the bias states the final vertical NEES (world z,
    1 dof) is inside the 99.9 % interval of chi2(6)/6 and the 3-dof position NEES inside that of
    chi2(18)/6; the same drives through the filter without them give a vertical NEES above the
    interval (the covariance the traverse datasets had: 4 sigma vertical errors on yutu-traverse)."""
    n = 6
    new = np.array([biased_run(stop_and_go, seed, True) for seed in range(n)])
    old = np.array([biased_run(stop_and_go, seed, False) for seed in range(n)])
    lo1, hi1 = chi2.ppf([0.0005, 0.9995], n) / n
    lo3, hi3 = chi2.ppf([0.0005, 0.9995], 3 * n) / n
    assert lo1 < new[:, 0].mean() < hi1, (new[:, 0], lo1, hi1)
    assert lo3 < new[:, 1].mean() < hi3, (new[:, 1], lo3, hi3)
    assert old[:, 0].mean() > hi1, (old[:, 0], hi1)
    assert np.sqrt(np.mean(new[:, 2] ** 2)) > 0.03      # the bias makes a height error worth testing (m)


def test_dead_reckoning_output_at_times_and_bad_input(traj):
    dr, truth, _ = run(traj, 0, 0.0, False)
    T, C = dr.at([dr.t_ns[10], dr.t_ns[10] + 1])
    assert np.array_equal(T[0], dr.T_w_b[10]) and C.shape == (2, 6, 6)
    with pytest.raises(SimError, match="outside"):
        dr.at([dr.t_ns[-1] + 10**9])
    with pytest.raises(SimError, match="slip_std"):
        DeadReckoningConfig(0.1, 100, slip_std=-1)


def test_filterpy_predict_moves_the_state_by_the_motion_model_and_P_by_F_and_Q():
    # MotionEKF is filterpy's EKF with the nonlinear motion model as predict_x: predict(u) gives
    # x = f(x, u) and filterpy's own P = F P F^T + Q (and saves the prior); F x alone is not the motion.
    from sim.sensors.deadreckoning import N_X, MotionEKF, _f, _num_jac
    rng = np.random.default_rng(7)
    ekf = MotionEKF(dim_x=N_X, dim_z=2)
    ekf.x = np.r_[1.0, -2.0, 0.3, 0.02, -0.01, 1.2, 0.05, 1e-3, -2e-3, 5e-4, 0.0, 0.0]
    A = rng.normal(size=(N_X, N_X))
    ekf.P = A @ A.T * 1e-3
    u = (np.array([0.01, -0.02, 0.3]), 0.01, 0.005)
    x0, P0 = ekf.x.copy(), ekf.P.copy()
    ekf.F = _num_jac(lambda xx: _f(xx, *u), x0)
    ekf.Q = np.eye(N_X) * 1e-6
    ekf.predict(u=u)
    np.testing.assert_array_equal(ekf.x, _f(x0, *u))
    np.testing.assert_allclose(ekf.P, ekf.F @ P0 @ ekf.F.T + ekf.Q, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ekf.x_prior, ekf.x)
    assert np.abs(ekf.F @ x0 - ekf.x).max() > 1e-3      # the linear F x misses the motion (7 mm in this step)
