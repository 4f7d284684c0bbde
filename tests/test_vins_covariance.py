"""VINS output covariance: the tangent-space map to T_o_c0 and the landmark Schur complement."""
import gtsam
import numpy as np
import pytest

from rigs.geometry import pose_error_left
from vo.vins.covariance import output_covariance, output_jacobian, pose_block_marginal


def _random_T(rng):
    T = np.eye(4)
    T[:3, :3] = gtsam.Rot3.Expmap(rng.normal(size=3)).matrix()
    T[:3, 3] = rng.normal(size=3)
    return T


def test_output_jacobian_matches_finite_differences():
    """J maps gtsam's right perturbation [dtheta, dt] of T_w_i to the left [dphi, dp] of T_o_c = T_o_w T_w_i T_i_c;
    central differences with h = 1e-6 agree to 1e-8 (second-order remainder h^2 ~ 1e-12, roundoff ~1e-10)."""
    rng = np.random.default_rng(3)
    T_o_w, T_w_i, T_i_c = _random_T(rng), _random_T(rng), _random_T(rng)
    J = output_jacobian(T_o_w, T_w_i, T_i_c)
    T_ref = T_o_w @ T_w_i @ T_i_c
    h = 1e-6
    for j in range(6):
        xi = np.zeros(6)
        xi[j] = h
        plus = T_o_w @ gtsam.Pose3(T_w_i).retract(xi).matrix() @ T_i_c
        minus = T_o_w @ gtsam.Pose3(T_w_i).retract(-xi).matrix() @ T_i_c
        # pose_error_left(true, est) = [log(R_true R_est^T), p_true - p_est]: "true" = perturbed pose
        d = (pose_error_left(plus[None], T_ref[None])[0] - pose_error_left(minus[None], T_ref[None])[0]) / (2 * h)
        assert np.allclose(d, J[:, j], atol=1e-8)


def test_output_covariance_is_symmetric_psd_and_maps_position():
    """A pure position covariance of the IMU maps to R_o_w R_w_i P R_w_i^T R_o_w^T on the camera position."""
    rng = np.random.default_rng(4)
    T_o_w, T_w_i, T_i_c = _random_T(rng), _random_T(rng), _random_T(rng)
    P = np.zeros((6, 6))
    P[3:, 3:] = np.diag([0.1, 0.2, 0.3]) ** 2
    C = output_covariance(P, T_o_w, T_w_i, T_i_c)
    A = T_o_w[:3, :3] @ T_w_i[:3, :3]
    assert np.allclose(C[3:, 3:], A @ P[3:, 3:] @ A.T, atol=1e-15) and np.allclose(C[:3], 0.0)
    assert np.allclose(C, C.T) and np.linalg.eigvalsh(C).min() > -1e-15


@pytest.mark.parametrize("d", [3, 1])         # Point3 / inverse-depth landmarks
def test_pose_block_marginal_equals_dense_inverse(d):
    """Schur complement over dxd landmark blocks = the corresponding block of the full inverse (to 1e-9 relative)."""
    rng = np.random.default_rng(5)
    n_s, m = 21, 15
    J = rng.normal(size=(200, n_s + d * m))
    for j in range(m):                      # landmark j appears only in its own rows (no landmark coupling)
        rows = np.r_[j * 12:(j + 1) * 12]
        mask = np.ones(J.shape[0], bool)
        mask[rows] = False
        J[mask, n_s + d * j:n_s + d * j + d] = 0.0
    H = J.T @ J + 1e-3 * np.eye(n_s + d * m)
    P = pose_block_marginal(H, n_s, d)
    P_ref = np.linalg.inv(H)[:6, :6]
    assert np.allclose(P, P_ref, rtol=1e-9, atol=1e-12 * np.abs(P_ref).max())


def test_consistency_runs_redraw_imu_noise_per_seed():
    """`vo-testbed consistency` re-noises the ideal IMU per run with the rig's Kalibr densities: different seeds
    give different samples, the same seed the same, and the gyro white noise has std density*sqrt(rate)
    (20000 samples x 3 axes: the sample std is within 2 % of it with > 99.9 % probability)."""
    from types import SimpleNamespace

    from rigs.presets import get_rig
    from sim.app.nees.runs import NoisyDataset
    from rigs.records import ImuSamples
    imu = get_rig("cart27").imu
    n = 20000
    t = 1_000_000_000 + np.arange(n, dtype=np.int64) * int(1e9 / imu.rate_hz)
    base = SimpleNamespace(imu=ImuSamples(t, np.zeros((n, 3)), np.zeros((n, 3))))
    a, b, a2 = (NoisyDataset(base, 1.0, s, imu_model=imu).imu for s in (1, 2, 1))
    assert not np.allclose(a.gyro, b.gyro) and np.array_equal(a.gyro, a2.gyro)
    white = np.diff(a.gyro, axis=0) / np.sqrt(2)          # removes the (slow) bias random walk
    assert abs(white.std() / (imu.gyro_noise_density * np.sqrt(imu.rate_hz)) - 1) < 0.02
