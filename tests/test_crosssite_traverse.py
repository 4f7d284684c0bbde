"""Traverse-level helpers of the cross-site localizer: the leg covariance of the dead-reckoning prior."""
import gtsam
import numpy as np

from rigs.geometry import make_T, rot_z
from vo.crosssite.localizer import relative_prior_cov
from vo.crosssite.types import Site, StereoCal, StereoPair


def _site(index, T, C):
    img = np.zeros((32, 32), np.uint8)
    cal = StereoCal(np.array([[30.0, 0, 16], [0, 30.0, 16], [0, 0, 1]]), make_T(np.eye(3), [0.27, 0, 0]), 32, 32)
    return Site(index, index, (StereoPair(img, img, np.eye(4)),), cal, T, C)


def test_relative_prior_cov_recovers_an_independent_leg():
    """C_k = Ad C_{k-1} Ad^T + Q (right perturbation carried through the drive D, plus an independent
    leg noise Q): the function returns Q exactly (to rounding)."""
    rng = np.random.default_rng(4)
    A = rng.standard_normal((6, 6))
    C_prev = 0.01 * A @ A.T + 1e-4 * np.eye(6)
    B = rng.standard_normal((6, 6))
    Q = 0.02 * B @ B.T + 1e-5 * np.eye(6)
    T_prev = make_T(rot_z(0.4), [3.0, -2.0, 0.1])
    D = make_T(rot_z(-0.3), [8.0, 1.0, 0.2])
    Ad = gtsam.Pose3(D).inverse().AdjointMap()
    C_cur = Ad @ C_prev @ Ad.T + Q
    out = relative_prior_cov(_site(0, T_prev, C_prev), _site(1, T_prev @ D, 0.5 * (C_cur + C_cur.T)))
    assert np.allclose(out, Q, atol=1e-10)


def test_relative_prior_cov_is_positive_definite_when_the_difference_is_not():
    """A current covariance smaller than the carried previous one (correlated legs): clipped, never
    indefinite."""
    C = np.diag([1e-4] * 3 + [1.0] * 3)
    out = relative_prior_cov(_site(0, np.eye(4), C), _site(1, make_T(np.eye(3), [5.0, 0, 0]), 0.5 * C))
    assert np.linalg.eigvalsh(out).min() > 0 and np.all(np.isfinite(out))
