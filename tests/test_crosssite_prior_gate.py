"""The post-BA prior gate of the cross-site localizer: ``prior_chi2`` is chi2(6) under the prior, and
the default gate ``prior_gate_chi2`` is a far-tail bound of it (seed-001 localizer, docs/crosssite.md)."""
import gtsam
import numpy as np
from scipy.stats import chi2

from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.localizer import prior_chi2

LEG_M = 8.5                                   # site pair 0->1 of yutu-traverse
COV = np.diag([0.03 ** 2] * 3 + [(0.15 * LEG_M) ** 2] * 3)   # the leg floor: 0.03 rad, 15 % of the leg


def _prior():
    T = np.eye(4)
    T[:3, :3] = gtsam.Rot3.Ypr(0.4, 0.02, -0.01).matrix()
    T[:3, 3] = [12.0, -3.0, 0.5]
    return T


def _perturbed(T, xi):
    return T @ gtsam.Pose3.Expmap(np.asarray(xi, float)).matrix()


def test_default_gate_is_a_far_tail_bound_of_chi2_6():
    gate = CrossSiteConfig().prior_gate_chi2
    assert chi2.sf(gate, 6) < 1e-5 and gate > chi2.ppf(0.999, 6)


def test_prior_chi2_is_chi2_6_under_the_prior():
    rng = np.random.default_rng(20261123)
    T0, L = _prior(), np.linalg.cholesky(COV)
    d2 = np.array([prior_chi2(T0, COV, _perturbed(T0, L @ rng.standard_normal(6))) for _ in range(4000)])
    # mean of chi2(6) is 6, variance 12: standard error of the mean over 4000 draws 0.055; 5 sigma bound
    assert abs(d2.mean() - 6.0) < 0.28
    # fraction above chi2(6)'s 0.99 quantile: 1 %; binomial standard error 0.0016, 5 sigma bound
    frac = (d2 > chi2.ppf(0.99, 6)).mean()
    assert abs(frac - 0.01) < 0.008


def test_gate_refuses_the_wrong_tie_solution():
    """A periodic-texture tie set put the BA 8.0 m from the truth on a leg whose dead reckoning erred
    by 0.86 m: its chi2 against the prior must be over the gate, the dead-reckoning pose's under it."""
    T0 = _prior()
    gate = CrossSiteConfig().prior_gate_chi2
    wrong = _perturbed(T0, [0, 0, 0, 8.0 / np.sqrt(2), 8.0 / np.sqrt(2), 0])
    assert prior_chi2(T0, COV, wrong) > gate
    honest = _perturbed(T0, [0.01, -0.01, 0.02, 0.86, 0.0, 0.0])
    assert prior_chi2(T0, COV, honest) < gate
