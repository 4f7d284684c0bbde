"""vo.crosssite.model_check: the eq. 9-13 model on a tie layout (the paper's numbers, the variants'
ordering) and the tie-point errors against exact correspondences on a synthetic two-site geometry
(a wall 10 m ahead of site 0, site 1 4 m closer), where every quantity is known in closed form."""
import numpy as np
import pytest

from rigs.geometry import make_T
from vo.crosssite import Site, StereoCal, StereoPair
from vo.crosssite.model_check import (axis_sigmas, ba_ties, model_covariance, pair_layout, robust_sigma,
                                      tie_errors_vs_depth)
from vo.crosssite.ties import TieSet
from vo.crosssite.types import SiteResult
from vo.errorprop.crosssite import CROSS_SITE_PRESETS, cross_site_accuracy

F, B, W = 100.0, 0.27, 64
K = np.array([[F, 0, 32.0], [0, F, 32.0], [0, 0, 1]])
CAL = StereoCal(K, make_T(np.eye(3), (B, 0, 0)), W, W)
T_B_C0 = make_T(np.array([[0, 0, 1.0], [-1, 0, 0], [0, -1, 0]]), (0.0, 0.0, 1.5))   # looks along body x
T0, T1 = np.eye(4), make_T(np.eye(3), (4.0, 0.0, 0.0))
WALL_X = 10.0


def _site(i, T):
    im = np.zeros((W, W), np.uint8)
    return Site(i, i, [StereoPair(im, im, T_B_C0)], CAL, T, np.eye(6) * 1e-2)


def _pixel(P_w, T_w_b):
    P_c = np.linalg.inv(T_w_b @ T_B_C0) @ np.r_[P_w, 1.0]
    return (K @ (P_c[:3] / P_c[2]))[:2], P_c[2]


@pytest.fixture
def exact():
    """Ties on the wall x = 10 m (y in [-1.2, 1.2], z in [0.9, 2.1]), exact in both sites."""
    P = np.array([(WALL_X, y, z) for y in (-1.2, -0.4, 0.4, 1.2) for z in (0.9, 1.5, 2.1)])
    uv0, z0 = zip(*[_pixel(p, T0) for p in P])
    uv1, z1 = zip(*[_pixel(p, T1) for p in P])
    uv0, uv1, z0, z1 = np.array(uv0), np.array(uv1), np.array(z0), np.array(z1)
    n = len(P)
    ties = TieSet(np.zeros(n, int), uv0, np.zeros(n, int), uv1, uv0[:, 0] - F * B / z0, uv1[:, 0] - F * B / z1,
                  np.ones(n, bool), np.ones(n, bool))
    res = SiteResult(1, "ok", T1.copy(), np.eye(6) * 1e-6, n, ties=ties)
    depth = np.full((W, W), WALL_X, np.float32)
    return _site(0, T0), _site(1, T1), res, P, depth


def test_paper_layout_gives_the_paper_model():
    """sigma_p_cur = 0 with the similarity is eq. 9-13 as in vo.errorprop.crosssite (1.06 % at 10 m); the
    rigid transform (scale fixed) can only be more certain, the current site's errors only less."""
    cfg = CROSS_SITE_PRESETS["paper-ff"]
    lm = np.array(cfg.landmarks)
    M = model_covariance(lm, (10.0, 0.0), 1189.0, 0.27, 1 / 3, 3.0)
    assert np.allclose(M, cross_site_accuracy(cfg).M_p, rtol=1e-12)
    assert np.sqrt(np.trace(M)) / 10.0 == pytest.approx(0.0106, abs=5e-5)
    rigid = model_covariance(lm, (10.0, 0.0), 1189.0, 0.27, 1 / 3, 3.0, scale=False)
    two = model_covariance(lm, (10.0, 0.0), 1189.0, 0.27, 1 / 3, 3.0, sigma_p_cur_px=1 / 3)
    assert np.linalg.eigvalsh(M - rigid).min() > -1e-12 and np.trace(M - rigid) > 0
    assert np.linalg.eigvalsh(two - M).min() > -1e-12 and np.trace(two - M) > 0
    along, cross = axis_sigmas(M, (10.0, 0.0))
    assert along == pytest.approx(np.sqrt(M[0, 0])) and cross == pytest.approx(np.sqrt(M[1, 1]))


def test_exact_ties_have_zero_error_and_perturbations_show_exactly(exact):
    prev, cur, res, P, depth = exact
    d0, d1, tr, at_prev = tie_errors_vs_depth(prev, cur, res, T0, T1, [depth])
    assert np.abs(d0).max() < 1e-9 and np.abs(d1).max() < 1e-9 and np.abs(tr).max() < 1e-9
    assert np.allclose(pair_layout(prev, res), P[:, :2], atol=1e-9)       # intersection at site 0, body xy
    res.ties.ur_prev[0] -= 0.5                                             # disparity +0.5 px at site 0
    res.ties.uv_cur[1, 0] += 0.6                                           # 0.6 px transfer error at site 1
    d0, d1, tr, at_prev = tie_errors_vs_depth(prev, cur, res, T0, T1, [depth])
    assert d0[0] == pytest.approx(0.5) and np.abs(np.delete(d0, 0)).max() < 1e-9
    assert tr[1, 0] == pytest.approx(0.6) and at_prev[1, 0] == pytest.approx(0.6 * 6.0 / 10.0)   # z_cur / z_prev
    assert robust_sigma([1.0, -1.0, 1.0, -1.0, np.nan]) == pytest.approx(1.4826)


def test_ba_ties_drop_a_tie_that_disagrees_with_the_pose(exact):
    prev, cur, res, _, _ = exact
    assert np.array_equal(ba_ties(prev, cur, res, T0, 2.0), np.arange(len(res.ties.inlier)))
    res.ties.uv_cur[3] += (10.0, 0.0)
    res.ties.inlier[5] = False
    kept = ba_ties(prev, cur, res, T0, 2.0)
    assert 3 not in kept and 5 not in kept and len(kept) == len(res.ties.inlier) - 2
