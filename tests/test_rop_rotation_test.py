"""The ROP/PnP rotation test in the metric of both covariances (vo.rop.rotation_test) against exact truth."""
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import binom

from rigs.geometry import inv_T, make_T, so3_exp, so3_log
from rigs.presets import get_rig
from vo.errors import EstimatorError
from vo.rop import adjust_rops, initial_eops
from vo.rop.adjustment import AdjustmentConfig
from vo.rop.ropset import exact_ropset
from vo.rop.rop_config import RopConfig
from vo.rop.rotation_test import (MIN_FACTOR_STEPS, RotationTester, chi2_threshold, pnp_rotation_cov,
                                  readjusted_step, rotation_test)

K = np.array([[400.0, 0, 360], [0, 400.0, 240], [0, 0, 1]])
T_KF_C = make_T(so3_exp(np.radians([0.5, 4.5, 0.3])), [0.05, -0.01, 0.07])   # a fast turn: 4.5 deg, 7 cm


def _spd(rng, sigma_deg: float, n: int) -> np.ndarray:
    """``n`` random (3,3) covariances with axis sigmas between 0.5 and 1.5 x ``sigma_deg`` (rad^2), (n,3,3)."""
    Q = np.linalg.qr(rng.standard_normal((n, 3, 3)))[0]
    s2 = np.radians(sigma_deg * rng.uniform(0.5, 1.5, (n, 3))) ** 2
    return Q @ (s2[:, :, None] * np.swapaxes(Q, 1, 2))


def _gauss(rng, C: np.ndarray) -> np.ndarray:
    """One draw from N(0, C[i]) per covariance, (n,3)."""
    return (np.linalg.cholesky(C) @ rng.standard_normal((len(C), 3, 1)))[:, :, 0]


def _draws(n: int, prob: float, offset_sigmas: float = 0.0, seed: int = 8) -> np.ndarray:
    """Fires of :func:`rotation_test` on ``n`` pairs of rotations drawn about random true ones with random known
    covariances (ROP: left perturbation, PnP: right), the PnP one moved by ``offset_sigmas`` of the sum along a
    random axis (0: the null hypothesis)."""
    rng = np.random.default_rng(seed)
    R = Rotation.from_rotvec(rng.normal(0, 0.3, (n, 3))).as_matrix()
    C_rop, C_pnp = _spd(rng, 0.05, n), _spd(rng, 0.03, n)
    R_rop = Rotation.from_rotvec(_gauss(rng, C_rop)).as_matrix() @ R
    e = _gauss(rng, C_pnp)
    if offset_sigmas:
        C = np.swapaxes(R, 1, 2) @ C_rop @ R + C_pnp
        a = rng.standard_normal((n, 3))
        a /= np.sqrt(np.einsum("ni,ni->n", a, np.linalg.solve(C, a[:, :, None])[:, :, 0]))[:, None]
        e = e + offset_sigmas * a
    R_pnp = R @ Rotation.from_rotvec(e).as_matrix()
    return np.array([rotation_test(R_rop[i], C_rop[i], R_pnp[i], C_pnp[i], prob).fires for i in range(n)])


@pytest.mark.slow
@pytest.mark.parametrize("prob", [0.99, 0.9])
def test_the_false_alarm_rate_is_one_minus_the_probability(prob):
    # 20000 draws under the null: the count of fires is Binomial(20000, 1 - prob); the test fails outside its
    # central 99.9 % interval (a 0.1 % chance for a correct test with this fixed seed, which passes)
    n = 20000
    k = int(_draws(n, prob).sum())
    lo, hi = binom.ppf(0.0005, n, 1 - prob), binom.ppf(0.9995, n, 1 - prob)
    assert lo <= k <= hi, (k, lo, hi)


def test_a_disagreement_of_six_sigmas_is_found():
    # d2 = |6 a + noise|^2 with |a| = 1 in the metric: non-central chi-square(3, 36) exceeds 11.34 with
    # probability 0.98; of 500 draws at least 94 % fire (binomial 99.9 % bound: 0.98 - 3.1 x 0.0063)
    assert _draws(500, 0.99, offset_sigmas=6.0).mean() >= 0.94


def test_the_threshold_is_the_chi_square_quantile():
    assert chi2_threshold(0.99) == pytest.approx(11.345, abs=1e-3)
    assert chi2_threshold(0.9) == pytest.approx(6.251, abs=1e-3)


def _pnp_scene(seed: int, noise_px: float):
    rng = np.random.default_rng(seed)
    P = np.c_[rng.uniform(-2, 2, (40, 2)), rng.uniform(3, 8, 40)]
    T_c_kf = inv_T(T_KF_C)
    p_c = P @ T_c_kf[:3, :3].T + T_c_kf[:3, 3]
    x = p_c[:, :2] / p_c[:, 2:] * 400 + [360, 240]
    return P, x + noise_px * rng.standard_normal(x.shape)


def _fit(P, x) -> np.ndarray:
    T_c_kf = inv_T(T_KF_C)
    rvec = cv2.Rodrigues(T_c_kf[:3, :3])[0]
    _, rvec, tvec = cv2.solvePnP(P, x, K, None, rvec, T_c_kf[:3, 3].copy(), True, cv2.SOLVEPNP_ITERATIVE)
    return inv_T(make_T(cv2.Rodrigues(rvec)[0], tvec.ravel()))


def test_the_pnp_covariance_predicts_the_monte_carlo_spread():
    # 300 re-noised fits (0.5 px): the predicted per-axis sigma agrees with the sample one within 15 % (the
    # sampling error of a standard deviation from 300 draws is 4 %), and the mean Mahalanobis distance of the
    # true error is 3 within 0.5 (chi-square 3 dof: the mean of 300 has standard error 0.14)
    errs, covs = [], []
    for i in range(300):
        P, x = _pnp_scene(i + 1, 0.5)
        T = _fit(P, x)
        errs.append(so3_log(T_KF_C[:3, :3].T @ T[:3, :3]))
        covs.append(pnp_rotation_cov(P, x, K, T, 3.0))
    E, C = np.array(errs), np.mean(covs, axis=0)
    assert np.allclose(np.sqrt(np.diag(C)), E.std(axis=0), rtol=0.15)
    d2 = [e @ np.linalg.solve(c, e) for e, c in zip(E, covs)]
    assert abs(np.mean(d2) - 3.0) < 0.5


def test_the_pnp_covariance_needs_six_inliers():
    P, x = _pnp_scene(1, 0.5)
    assert pnp_rotation_cov(P[:5], x[:5], K, T_KF_C, 3.0) is None
    assert pnp_rotation_cov(P, x + 50.0, K, T_KF_C, 3.0) is None     # none within the inlier gate


def _run_tester(scale: float, n: int = 400, seed: int = 3):
    """Fires of :class:`RotationTester` over ``n`` steps whose true disagreement has ``scale`` x the stated
    covariances (a model error common to the run), through :meth:`RotationTester.miss`'s statistic."""
    rng = np.random.default_rng(seed)
    t = RotationTester(0.99, 2.0, 80.0, 1.0)
    fires = []
    C_rop, C_pnp = _spd(rng, 0.05, n), _spd(rng, 0.03, n)
    R = Rotation.from_rotvec(rng.normal(0, 0.3, (n, 3))).as_matrix()
    R_rop = Rotation.from_rotvec(np.sqrt(scale) * _gauss(rng, C_rop)).as_matrix() @ R
    R_pnp = R @ Rotation.from_rotvec(np.sqrt(scale) * _gauss(rng, C_pnp)).as_matrix()
    for i in range(n):
        res = rotation_test(R_rop[i], C_rop[i], R_pnp[i], C_pnp[i], t.prob)
        s2 = t.variance_factor()
        t.d2.append(res.d2)
        fires.append(s2 is not None and res.d2 / s2 > res.threshold)
    return np.array(fires), t


def test_the_variance_factor_keeps_the_false_alarm_rate_under_a_common_model_error():
    # covariances 25x optimistic: the plain test fires on most steps (P(chi2_3 > 11.34 / 25) = 0.93), the
    # run's variance factor (median d2 / 2.37 = 25 within the median's sampling error) brings it back to
    # about 1 %: at most 4 % of 400 steps (binomial 99.9 % bound of 1 %: 12 of 400 = 3 %, plus the factor's error)
    fires, t = _run_tester(25.0)
    assert not fires[:MIN_FACTOR_STEPS].any()                      # no test before the factor exists
    assert 20 < t.variance_factor() < 31
    assert fires.mean() <= 0.04
    plain = np.array(t.d2) > chi2_threshold(0.99)
    assert plain.mean() > 0.85


def test_the_variance_factor_never_shrinks_the_covariances():
    _, t = _run_tester(0.01, n=50)
    assert t.variance_factor() == 1.0


def test_the_rotation_test_options_are_validated():
    c = RopConfig()
    assert (c.pnp_rotation_test, c.pnp_rotation_prob, c.pnp_rotation_action) == ("chi2", 0.99, "direction")
    assert RopConfig.from_options({"pnp_rotation_prob": 0.999}).pnp_rotation_prob == 0.999
    with pytest.raises(EstimatorError, match="rop.pnp_rotation_prob"):
        RopConfig.from_options({"pnp_rotation_prob": 1.0})
    with pytest.raises(EstimatorError, match="rop.pnp_rotation_test"):
        RopConfig.from_options({"pnp_rotation_test": "angle"})
    with pytest.raises(EstimatorError, match="rop.pnp_rotation_action"):
        RopConfig.from_options({"pnp_rotation_action": "both"})


def _stereo_view(noise_px: float, seed: int):
    """Keyframe stereo tracks and current left points of 60 points 3-9 m ahead, cart27 rig (lens model), T_KF_C."""
    rng = np.random.default_rng(seed)
    rig = get_rig("cart27")
    p_kf = np.c_[rng.uniform(-2, 2, (60, 2)), rng.uniform(3, 9, 60)]
    c0, c1 = rig.cameras[:2]
    T_c1_c0, T_c_kf = inv_T(rig.T_c0_c1), inv_T(T_KF_C)
    pts = [c0.project(p_kf), c1.project(p_kf @ T_c1_c0[:3, :3].T + T_c1_c0[:3, 3]),
           c0.project(p_kf @ T_c_kf[:3, :3].T + T_c_kf[:3, 3])]
    p1, p2, p3 = (p + noise_px * rng.standard_normal(p.shape) for p in pts)
    return SimpleNamespace(p1=p1, p2=p2, p3=p3), rig


def test_the_tester_passes_agreeing_steps_and_fails_a_rotation_off_by_half_a_degree():
    # the PnP pose is the truth, its covariance from the tracks (0.3 px noise); the ROP rotation is drawn with
    # its stated covariance (0.03 deg per axis): after the warm-up no step fails at 99 % (of 20 steps, P(any)
    # = 18 %: the fixed seed's draw passes), and one 0.5 deg off (> 10 sigmas) fails
    rng = np.random.default_rng(5)
    t = RotationTester(0.99, 2.0, 80.0, 1.0)
    cov = np.diag(np.r_[np.full(3, np.radians(0.03) ** 2), np.full(3, 1e-4)])
    for i in range(20):
        view, rig = _stereo_view(0.3, i)
        R = so3_exp(rng.multivariate_normal(np.zeros(3), cov[:3, :3])) @ T_KF_C[:3, :3]
        assert t.miss(make_T(R, T_KF_C[:3, 3]), cov, T_KF_C, view, rig) == ""
    assert len(t.d2) == 20 and t.variance_factor() >= 1.0
    off = make_T(so3_exp(np.radians([0.0, 0.5, 0.0])) @ T_KF_C[:3, :3], T_KF_C[:3, 3])
    assert "Mahalanobis" in t.miss(off, cov, T_KF_C, view, rig)
    assert t.miss(off, cov, None, view, rig) == ""                    # no PnP pose: no check


def test_the_readjusted_step_keeps_the_rops_scale_with_the_given_rotation_and_direction():
    # exact ROPs of a 0.6 m step: with the true rotation, seed 000's step 2 re-solved returns the true step; with a
    # PnP translation 10 % long (a calibration scale error) as the direction, the length stays the ROPs' (exact)
    T_c1_c2 = make_T(so3_exp(np.radians([0.0, -0.76, 0.8])), [0.2857, 0.0005, -0.0041])
    T13 = make_T(so3_exp([0.01, 0.03, -0.005]), [0.05, -0.02, 0.6])
    rops = exact_ropset(T13, T_c1_c2)
    res = adjust_rops(rops, initial_eops(rops))
    np.testing.assert_allclose(readjusted_step(rops, res, T13[:3, :3], AdjustmentConfig()), T13, atol=1e-9)
    T = readjusted_step(rops, res, T13[:3, :3], AdjustmentConfig(), 1.1 * T13[:3, 3])
    np.testing.assert_allclose(T, T13, atol=1e-9)
    # a rotation 0.5 deg off: the re-solved translation follows it, the length stays within 1 % of the true one
    R_off = so3_exp(np.radians([0.0, 0.5, 0.0])) @ T13[:3, :3]
    T = readjusted_step(rops, res, R_off, AdjustmentConfig())
    np.testing.assert_allclose(T[:3, :3], R_off)
    assert abs(np.linalg.norm(T[:3, 3]) / np.linalg.norm(T13[:3, 3]) - 1) < 0.01
