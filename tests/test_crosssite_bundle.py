"""Seed 001 eq. 4-5: the cross-site BA on exact synthetic tie points (3-D points projected through
both sites' stereo pairs) recovers the current site's pose exactly without noise and within its
``Marginals`` covariance with 0.3 px noise; the space intersection and resection (eq. 3) are exact."""
import gtsam
import numpy as np
import pytest
from scipy.stats import chi2

from rigs.geometry import inv_T, make_T, rot_z
from rigs.presets import get_rig
from vo.crosssite.bundle import TieObservations, bundle_adjust
from vo.crosssite.intersect_resect import intersect_rectified, resection, right_from_left
from vo.crosssite.types import mast_T_b_c

RIG = get_rig("yutu-navcam")
K = RIG.cameras[0].K
B = RIG.baseline
T_B_MAST = make_T(np.eye(3), (0.3, 0.0, 1.5))
T_HEAD_C = inv_T(T_B_MAST) @ RIG.cameras[0].T_b_c_array
PANS = np.radians([-26.0, 0.0, 26.0])
T_W_B0 = make_T(rot_z(0.3), (10.0, -4.0, 0.0))
T_B0_B1 = make_T(rot_z(np.radians(8.0)), (7.0, 1.0, 0.05))


def pairs():
    return [mast_T_b_c(T_B_MAST, p, 0.0, T_HEAD_C) for p in PANS]


def project(T_w_b, T_b_c0s, P_w):
    """Rows (pair, point, u_l, v, u_r) of every point seen by both cameras of a pair with disparity > 2 px."""
    rows = []
    for j, T_b_c0 in enumerate(T_b_c0s):
        P_c = (inv_T(T_w_b @ T_b_c0) @ np.c_[P_w, np.ones(len(P_w))].T).T[:, :3]
        uv = (K @ P_c.T).T
        uv = uv[:, :2] / uv[:, 2:]
        ur = uv[:, 0] - K[0, 0] * B / P_c[:, 2]
        ok = (P_c[:, 2] > 0.5) & (uv[:, 0] > 0) & (uv[:, 0] < 1023) & (uv[:, 1] > 0) & (uv[:, 1] < 1023) & (ur > 0)
        rows += [(j, p, uv[p, 0], uv[p, 1], ur[p]) for p in np.flatnonzero(ok)]
    return np.array(rows)


def scenario(rng, sigma_px):
    """Ground points in front of both sites, observations at both, noisy by sigma_px on (u_l, u_r, v)."""
    T_w_b1 = T_W_B0 @ T_B0_B1
    P_b0 = np.column_stack([rng.uniform(8, 20, 300), rng.uniform(-8, 8, 300), rng.uniform(-0.1, 0.4, 300)])
    P_w = (T_W_B0 @ np.c_[P_b0, np.ones(300)].T).T[:, :3]
    site, pair, point, uvl, ur = [], [], [], [], []
    for s, T in enumerate((T_W_B0, T_w_b1)):
        r = project(T, pairs(), P_w)
        site += [s] * len(r)
        pair += r[:, 0].astype(int).tolist()
        point += r[:, 1].astype(int).tolist()
        uvl.append(r[:, 2:4])
        ur.append(r[:, 4])
    n = len(site)
    noise = rng.standard_normal((n, 3)) * sigma_px
    obs = TieObservations(np.array(site), np.array(pair), np.array(point),
                          np.vstack(uvl) + noise[:, :2], np.concatenate(ur) + noise[:, 2])
    both = set(obs.point[obs.site == 0].tolist()) & set(obs.point[obs.site == 1].tolist())
    keep = np.isin(obs.point, list(both))
    obs = TieObservations(*(a[keep] for a in (obs.site, obs.pair, obs.point, obs.uv_l, obs.u_r)))
    return obs, P_w, T_w_b1


def pose_error(T_hat, T_true):
    return gtsam.Pose3.Logmap(gtsam.Pose3(T_hat).between(gtsam.Pose3(T_true)))


def run(seed, sigma_px, **kw):
    rng = np.random.default_rng(seed)
    obs, P_w, T_w_b1 = scenario(rng, sigma_px)
    T_init = T_w_b1 @ make_T(rot_z(0.02), (0.3, -0.2, 0.05))
    P0 = P_w + rng.normal(0, 0.2, P_w.shape)
    res = bundle_adjust(T_W_B0, T_init, [pairs(), pairs()], obs, P0, K, B, sigma_px=max(sigma_px, 0.3), **kw)
    return res, T_w_b1, len(set(obs.point.tolist()))


@pytest.mark.parametrize("mast", [0.0, 1e-6])
def test_exact_tie_points_give_the_exact_pose(mast):
    """Hard mast constraint (body_P_sensor) and soft one (BetweenFactorPose3 to per-pair poses)."""
    res, T_true, n = run(0, 0.0, mast_sigma_rad=mast, mast_sigma_m=mast)
    assert n > 50
    e = pose_error(res.T_w_b, T_true)
    assert np.abs(e[3:]).max() < 1e-6 and np.abs(e[:3]).max() < 1e-8


def test_noisy_tie_points_lie_within_the_marginal_covariance():
    """0.3 px on u_l, u_r, v (the noise the factors assume). One seed: chi-square(6) at 99.9 %; 12
    seeds: the mean NEES inside the 99.9 % interval of chi2(72)/12, i.e. the covariance is neither
    too small nor too large (Huber with k=1.345 costs ~5 % efficiency, inside this band)."""
    nees = []
    for seed in range(12):
        res, T_true, _ = run(seed + 1, 0.3)
        e = pose_error(res.T_w_b, T_true)
        nees.append(e @ np.linalg.solve(res.cov, e))
    assert nees[0] < chi2.ppf(0.999, 6)
    lo, hi = chi2.ppf([0.0005, 0.9995], 72) / 12
    assert lo < np.mean(nees) < hi, (np.mean(nees), lo, hi)


def test_intersection_resection_and_eq3_are_exact():
    rng = np.random.default_rng(3)
    obs, P_w, T_w_b1 = scenario(rng, 0.0)
    m = (obs.site == 0) & (obs.pair == 1)
    P_c = intersect_rectified(obs.uv_l[m], obs.u_r[m], K, B)
    T_w_c = T_W_B0 @ pairs()[1]
    P_w_hat = (T_w_c @ np.c_[P_c, np.ones(len(P_c))].T).T[:, :3]
    assert np.abs(P_w_hat - P_w[obs.point[m]]).max() < 1e-9
    m1 = (obs.site == 1) & (obs.pair == 1)
    T_true = T_w_b1 @ pairs()[1]
    T_hat, inl = resection(P_w[obs.point[m1]], obs.uv_l[m1], K, T_true @ make_T(rot_z(0.05), (0.2, 0, 0)), 1.0)
    assert len(inl) == m1.sum() and np.abs(T_hat - T_true).max() < 1e-6
    assert np.allclose(right_from_left(T_true, RIG.T_c0_c1), T_w_b1 @ RIG.cameras[1].T_b_c_array, atol=1e-12)


def test_cross_site_matching_error_in_the_weights_gives_a_consistent_covariance():
    """A cross-site matching error of 1.5 px on the current site's observations (common to u_l and u_r,
    and on v: the stereo match follows the matched left pixel) on top of 0.3 px stereo noise. With it
    in the BA's observation covariance (``xsite_sigma_px``) the mean pose NEES over 12 seeds lies in
    the 99.9 % interval of chi2(72)/12; with the stereo sigma alone the covariance is over-confident
    and the NEES lies above that interval."""
    lo, hi = chi2.ppf([0.0005, 0.9995], 72) / 12
    nees = {0.0: [], 1.5: []}
    for seed in range(12):
        rng = np.random.default_rng([0x0B0A, seed])
        obs, P_w, T_true = scenario(rng, 0.3)
        cur = obs.site == 1
        m = rng.standard_normal((int(cur.sum()), 2)) * 1.5
        uv_l, u_r = obs.uv_l.copy(), obs.u_r.copy()
        uv_l[cur] += m
        u_r[cur] += m[:, 0]
        obs = TieObservations(obs.site, obs.pair, obs.point, uv_l, u_r)
        for xs in nees:
            res = bundle_adjust(T_W_B0, T_true @ make_T(rot_z(0.02), (0.3, -0.2, 0.05)), [pairs(), pairs()], obs,
                                P_w + rng.normal(0, 0.2, P_w.shape), K, B, sigma_px=0.3, xsite_sigma_px=xs, reject_px=1e3)
            e = pose_error(res.T_w_b, T_true)
            nees[xs].append(e @ np.linalg.solve(res.cov, e))
    assert lo < np.mean(nees[1.5]) < hi, (np.mean(nees[1.5]), lo, hi)
    assert np.mean(nees[0.0]) > hi, (np.mean(nees[0.0]), hi)
