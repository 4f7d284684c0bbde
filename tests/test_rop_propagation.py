"""Covariance propagation of per-ROP covariances through the adjustment, against Monte-Carlo."""
import numpy as np
import pytest

from rigs.geometry import R_from_opk_deg, make_T, so3_exp, so3_log
from vo.rop import adjust_rops
from vo.rop.relative import RopMeasurement, project_cov, rop_from_opencv
from vo.rop.ropset import RopSet, exact_ropset

T_C1_C2 = make_T(R_from_opk_deg(-0.01406, -0.75671, 0.80437), [0.2857, 0.0005, -0.0041])
T_TRUE = make_T(so3_exp([0.01, -0.03, 0.005]), [0.04, -0.01, 0.6])
# unequal, correlated per-ROP precision (rad): ROP 13/24 weak (forward motion), cross pairs strong
SIG = {"13": (2e-3, 8e-3), "14": (6e-4, 3e-3), "23": (5e-4, 2.5e-3), "24": (2e-3, 9e-3)}


def _cov6(m, s_rot, s_dir, rho=0.5):
    """[dphi, d rhat] covariance: isotropic rotation, tangent direction, correlation ``rho`` on one axis."""
    P = np.eye(3) - np.outer(m.rhat_i_j, m.rhat_i_j)
    C = np.zeros((6, 6))
    C[:3, :3], C[3:, 3:] = s_rot ** 2 * np.eye(3), s_dir ** 2 * P
    C[3:, :3] = rho * s_rot * s_dir * P @ np.diag([0.0, 1.0, 0.0])       # rotation about y <-> direction
    C[:3, 3:] = C[3:, :3].T
    return C


def _sample(rng, m, C):
    """One draw of a ROP with covariance ``C`` (rank 5: the direction stays a unit vector)."""
    w, V = np.linalg.eigh(C)
    d = V @ (np.sqrt(np.clip(w, 0, None)) * rng.standard_normal(6))
    r = m.rhat_i_j + d[3:]
    return RopMeasurement(so3_exp(d[:3]) @ m.R_i_j, r / np.linalg.norm(r), 100, np.ones(100, bool), True, cov6=C)


@pytest.mark.parametrize("weighting", ["inliers", "sampson"])
def test_propagated_covariance_matches_monte_carlo(weighting):
    """1000 draws; the sample covariance of [phi3, r3] matches the prediction: per-axis std within
    15 % (a 1000-sample std has ~2.2 % sampling error; 15 % allows the first-order linearisation)."""
    rng = np.random.default_rng(7)
    ex = exact_ropset(T_TRUE, T_C1_C2)
    covs = {p: _cov6(m, *SIG[p]) for p, m in ex.rops.items()}
    errs, pred = [], None
    for _ in range(1000):
        rops = {p: _sample(rng, m, covs[p]) for p, m in ex.rops.items()}
        for p, (sr, sd) in SIG.items():          # sigmas for the "sampson" weights
            rops[p] = rops[p].__class__(**{**rops[p].__dict__, "sigma_rot_rad": sr, "sigma_dir_rad": sd})
        res = adjust_rops(RopSet(rops, T_C1_C2, weighting))
        pred = res.cov_propagated if pred is None else pred
        errs.append(np.r_[so3_log(res.T_c1_c3[:3, :3] @ T_TRUE[:3, :3].T), res.T_c1_c3[:3, 3] - T_TRUE[:3, 3]])
    S = np.cov(np.array(errs).T)
    ratio = np.sqrt(np.diag(S) / np.diag(pred))
    assert np.all(np.abs(ratio - 1) < 0.15), ratio


def test_project_cov_matches_finite_differences():
    """``project_cov``'s Jacobian (OpenCV (R, t) -> R_i_j, rhat_i_j) against numerical derivatives."""
    R, t = so3_exp([0.02, -0.1, 0.03]), np.array([0.1, -0.05, -0.99])
    t /= np.linalg.norm(t)
    B = np.linalg.svd(t.reshape(1, 3))[2][1:].T
    R0, r0 = rop_from_opencv(R, t)
    J = np.zeros((6, 5))
    h = 1e-7
    for k in range(5):
        dz = np.zeros(5)
        dz[k] = h
        tk = t + B @ dz[3:]
        Rk, rk = rop_from_opencv(so3_exp(dz[:3]) @ R, tk / np.linalg.norm(tk))
        J[:3, k], J[3:, k] = so3_log(Rk @ R0.T) / h, (rk - r0) / h
    cov5 = np.diag([1.0, 2.0, 3.0, 4.0, 5.0]) * 1e-6
    np.testing.assert_allclose(project_cov(R, t, cov5), J @ cov5 @ J.T, rtol=2e-3, atol=1e-12)   # forward differences, h = 1e-7


def test_propagate_cov_matches_monte_carlo_of_composed_steps():
    """Keyframe chaining ``T_o_c3 = T_o_c1 @ T_c1_c3`` (vo.rop.uncertainty.propagate_cov) against
    composing independently perturbed poses (left perturbation ``[rotvec, position]``)."""
    from vo.rop.uncertainty import propagate_cov
    rng = np.random.default_rng(7)
    T1 = make_T(so3_exp([0.1, 0.4, -0.2]), [0.3, -0.1, 2.0])
    C1 = np.diag([3e-3, 2e-3, 4e-3, 5e-3, 4e-3, 6e-3]) ** 2
    C2 = np.diag([1e-3, 2e-3, 1e-3, 1e-3, 1e-3, 3e-3]) ** 2
    P = propagate_cov(C1, T1, T_TRUE, C2)
    L1, L2 = np.linalg.cholesky(C1), np.linalg.cholesky(C2)
    Tn = T1 @ T_TRUE

    def perturb(T, e):
        return make_T(so3_exp(e[:3]) @ T[:3, :3], T[:3, 3] + e[3:])

    E = []
    for _ in range(4000):
        T = perturb(T1, L1 @ rng.standard_normal(6)) @ perturb(T_TRUE, L2 @ rng.standard_normal(6))
        E.append(np.r_[so3_log(T[:3, :3] @ Tn[:3, :3].T), T[:3, 3] - Tn[:3, 3]])
    ratio = np.sqrt(np.diag(np.cov(np.array(E).T)) / np.diag(P))
    assert np.all(np.abs(ratio - 1) < 0.06), ratio
