"""IMU checks that print the issue's figures: dead reckoning of the ideal IMU, Allan deviation of noise."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from rigs.geometry import so3_log
from rigs.imu_models import get_imu_model
from rigs.records import ImuSamples
from sim.allan import allan_deviation, density_at_1s, fit_white_and_walk, loglog_slope
from sim.generate import resolve
from sim.generate_config import GenerateConfig
from sim.rng import stream
from sim.sensors.imu import imu_pose_velocity, integrate_imu, measure_imu
from sim.sensors.imu_noise import add_imu_noise


@dataclass(frozen=True)
class DeadReckoningResult:
    scene: str
    rig: str
    duration_s: float
    rate_hz: float
    path_length_m: float
    position_error_m: float
    attitude_error_deg: float
    velocity_error_mps: float

    def to_dict(self) -> dict:
        return asdict(self)

    def text(self) -> str:
        return (f"ideal {self.rate_hz:g} Hz IMU dead-reckoned for {self.duration_s:g} s over {self.path_length_m:.1f} m "
                f"({self.scene}, {self.rig}): position error {self.position_error_m:.3e} m, attitude error "
                f"{self.attitude_error_deg:.3e} deg, velocity error {self.velocity_error_mps:.3e} m/s")


def dead_reckoning(scene: str = "campus", rig: str = "cart27", duration_s: float = 60.0, seed: int = 0,
                   overrides=()) -> DeadReckoningResult:
    """Integrate the exact (``--ideal``) IMU from the true initial state; compare with the truth at the end."""
    setup = resolve(GenerateConfig(scene=scene, rig=rig, duration_s=duration_s, seed=seed, ideal=True,
                                   images=False).with_overrides(tuple(overrides)))
    T_b_i = setup.rig.imu.T_b_i_array
    samples = measure_imu(setup.trajectory, setup.rig.imu, setup.imu_t_ns)
    T_true, v_true = imu_pose_velocity(setup.trajectory.states(setup.imu_t_ns), T_b_i)
    T_est, v_est = integrate_imu(samples, T_true[0], v_true[0])
    dR = T_true[-1, :3, :3] @ T_est[-1, :3, :3].T
    done_s = (setup.trajectory.t1_ns - setup.trajectory.t0_ns) * 1e-9      # a route or replay may end first
    return DeadReckoningResult(scene, rig, done_s, setup.rig.imu.rate_hz, float(setup.trajectory.path_length()),
                               float(np.linalg.norm(T_true[-1, :3, 3] - T_est[-1, :3, 3])),
                               float(np.degrees(np.linalg.norm(so3_log(dR)))),
                               float(np.linalg.norm(v_true[-1] - v_est[-1])))


@dataclass(frozen=True)
class AllanResult:
    imu: str
    hours: float
    gyro_density: float
    gyro_adev_1s: float
    gyro_ratio_1s: float
    accel_density: float
    accel_white_fit: float
    accel_ratio_fit: float
    gyro_rw_slope: float

    def to_dict(self) -> dict:
        return asdict(self)

    def text(self) -> str:
        return "\n".join([
            f"static {self.imu} IMU, {self.hours:g} h at 200 Hz (seeded streams imu_white/imu_bias):",
            f"  gyro  ADEV(1 s) {self.gyro_adev_1s:.4e} vs white density {self.gyro_density:.4e}: ratio {self.gyro_ratio_1s:.3f}",
            f"  accel white density from the ADEV fit {self.accel_white_fit:.4e} vs {self.accel_density:.4e}: "
            f"ratio {self.accel_ratio_fit:.3f}",
            f"  gyro log-log slope at long tau with the random walk x100 (1 s to T/20, mean of 3 axes): "
            f"{self.gyro_rw_slope:+.3f} (expected +0.5)"])


def allan_check(imu_name: str = "euroc-adis16448", hours: float = 2.0, seed: int = 0,
                rw_scale: float = 100.0) -> AllanResult:
    """Allan deviation of a static noisy IMU. The random-walk slope is read with the gyro random walk
    scaled by ``rw_scale`` so the +1/2 region appears within ``hours`` (documented in the output)."""
    import dataclasses

    imu = get_imu_model(imu_name)
    n = int(hours * 3600 * imu.rate_hz)
    t_ns = np.arange(n, dtype=np.int64) * int(round(1e9 / imu.rate_hz))
    clean = ImuSamples(t_ns, np.zeros((n, 3)), np.zeros((n, 3)))
    noisy, _ = add_imu_noise(clean, imu, stream(seed, "imu_white"), stream(seed, "imu_bias"))
    taus = np.logspace(-1.5, np.log10(hours * 3600 / 10), 40)
    tg, ag = allan_deviation(noisy.gyro[:, 0], imu.rate_hz, taus)
    ta, aa = allan_deviation(noisy.accel[:, 0], imu.rate_hz, taus)
    walk = dataclasses.replace(imu, gyro_random_walk=imu.gyro_random_walk * rw_scale)
    noisy_w, _ = add_imu_noise(clean, walk, stream(seed + 1, "imu_white"), stream(seed + 1, "imu_bias"))
    tw, aw = allan_deviation(noisy_w.gyro, imu.rate_hz, taus)          # (K, 3): all three axes
    g1 = density_at_1s(tg, ag)
    a_white, _ = fit_white_and_walk(ta, aa)
    slope = float(np.mean([loglog_slope(tw, aw[:, j], 1.0, hours * 3600 / 20) for j in range(3)]))
    return AllanResult(imu_name, hours, imu.gyro_noise_density, g1, g1 / imu.gyro_noise_density,
                       imu.accel_noise_density, a_white, a_white / imu.accel_noise_density, slope)
