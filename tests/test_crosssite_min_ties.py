"""The localizer's minimum BA tie count (``CrossSiteConfig.min_ba_ties``): a set of 8 ties with 2 planted
false matches (30 px off) keeps the dead-reckoning pose (``few_tie_points``, covariance inflated); the
same 2 false matches among 30 true ties give ``ok`` at the exact pose. Exact synthetic ties: points seen
by the previous site's stereo at their true depth, current pixels by projection (stages 1-5 replaced)."""
import dataclasses

import numpy as np

from rigs.geometry import make_T, rot_z
from vo.crosssite import localizer
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.regions import project
from vo.crosssite.ties import TieSet
from vo.crosssite.types import Site, StereoCal, StereoPair

K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
B = 0.27
T_B_C = make_T(np.array([[0, 0, 1.0], [-1, 0, 0], [0, -1, 0]]), [0, 0, 1.5])
T0 = np.eye(4)
T1 = make_T(rot_z(0.1), [8.0, 0.5, 0.0])
T_PRIOR = make_T(rot_z(0.12), [7.4, 0.9, 0.0])
COV = np.diag([0.03 ** 2] * 3 + [1.2 ** 2] * 3)


def _sites():
    cal = StereoCal(K, make_T(np.eye(3), [B, 0, 0]), 640, 480)
    img = np.zeros((480, 640), np.uint8)
    prev = Site(0, 0, (StereoPair(img, img, T_B_C),), cal, T0, np.eye(6) * 1e-4)
    return prev, Site(1, 1, (StereoPair(img, img, T_B_C),), cal, T_PRIOR, COV)


def _ties(n_true: int, rng) -> TieSet:
    """``n_true`` exact ties and 2 false ones (current pixels moved 30 px), eq. 2 passed."""
    n = n_true + 2
    P_w = np.column_stack([rng.uniform(12, 30, n), rng.uniform(-5, 5, n), rng.uniform(-0.3, 0.3, n)])
    uv0, z0 = project(T0 @ T_B_C, K, P_w)
    uv1, z1 = project(T1 @ T_B_C, K, P_w)
    uv1[n_true:] += [[30.0, 0.0], [0.0, -30.0]]
    t = TieSet(np.zeros(n, int), uv0, np.zeros(n, int), uv1)
    t.ur_prev, t.ur_cur = uv0[:, 0] - K[0, 0] * B / z0, uv1[:, 0] - K[0, 0] * B / z1
    t.stereo_ok, t.inlier = np.ones(n, bool), np.ones(n, bool)
    return t


def _localize(monkeypatch, ties, cfg):
    monkeypatch.setattr(localizer, "_ties", lambda *a: (ties, {}))
    prev, cur = _sites()
    return localizer._localize_site(prev, T0, cur, cfg)


def test_eight_ties_with_two_false_keep_the_prior(monkeypatch):
    cfg = CrossSiteConfig()
    r = _localize(monkeypatch, _ties(6, np.random.default_rng(3)), cfg)
    assert r.status == "few_tie_points" and "min_ba_ties" in r.reason
    assert np.allclose(r.T_w_b, T_PRIOR) and np.allclose(r.cov, COV * cfg.inflate)


def test_two_false_among_thirty_true_are_ok(monkeypatch):
    r = _localize(monkeypatch, _ties(30, np.random.default_rng(3)), CrossSiteConfig())
    assert r.status == "ok" and r.stats["n_ba_points"] == 30                  # the false ones left by the resection
    assert np.linalg.norm(r.T_w_b[:3, 3] - T1[:3, 3]) < 1e-3                   # exact ties: the exact pose


def test_rule_is_what_rejects_the_small_set(monkeypatch):
    """With the count at the resection's own minimum the same 6 true ties give ``ok`` at the exact pose."""
    cfg = dataclasses.replace(CrossSiteConfig(), min_ba_ties=6)
    r = _localize(monkeypatch, _ties(6, np.random.default_rng(3)), cfg)
    assert r.status == "ok" and np.linalg.norm(r.T_w_b[:3, 3] - T1[:3, 3]) < 1e-3
