"""Label-free rigidity test across frames: seed 001's distance invariance between landmark pairs (eq. 2).

In a static rigid world the 3-D distance between two points does not depend on the stereo pair that
measured them: with ``p_a``, ``p_b`` one landmark's stereo positions at two epochs (each in its own frame:
the keyframe's, the current camera's, or the odometry frame) and ``q_a``, ``q_b`` a partner's,

    e = | |p_a - q_a| - |p_b - q_b| |                               (seed 001, eq. 2)

vanishes up to the stereo measurement error, whatever the motion between the epochs, so the test needs no
pose. A landmark on a moving actor, or a corner on an occlusion boundary (a T-junction: the junction slides
along the far surface as the camera moves, so its stereo point moves), breaks the invariance with most
partners. Seed 001 counts for each point the partners it agrees with (``e <= e_L``) and drops the points
with too few; here ``e_L`` comes from the propagated stereo covariance instead of a fixed length (the
seed's section 3.1): a point at range ``r`` from its stereo pair has the range error
``sigma_r = r^2 sigma_p / (b f)`` (eq. 7) along its ray and ``r sigma_px / f`` across it (eq. 8's bearing
term, in 3-D), and the pair ``(i, j)`` violates the invariance when

    e^2 > chi2_gate * (u_a^T (S_ia + S_ja) u_a + u_b^T (S_ib + S_jb) u_b)

(``u`` the unit pair direction at each epoch; first-order variance of ``e``, a chi-square test with one
degree of freedom). Each landmark is tested against ``partners`` others drawn from a seeded stream among
the informative ones: a pair is only as sharp as its less precise point, so the partners of a landmark are
drawn from those at least as precise as it (or as the ``partner_quantile`` quantile of the points, if that
is larger), which keeps a near car's points from being compared with far points only; its
violated fraction is counted in two rounds, the second over the partners the first round left
(a consistent set: a bad partner does not count against a good point). A landmark whose fraction exceeds
``max_violation_fraction`` is flagged.

Which set the test runs on is the caller's choice: the estimators run it on the landmarks of the rigid
motion they already chose (the PnP inliers of ``klt-pnp``, the kept tracks of ``rop``'s track filter), so a
car that holds most landmarks cannot turn the static world into the "violating" minority
(:func:`rigid_subset`, docs/estimators.md "Rigidity test across frames").
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import cv2
import numpy as np

from vo.errors import VoError


@dataclass(frozen=True)
class RigidityConfig:
    """``enabled`` run the test; ``partners`` pairs per landmark; ``disparity_sigma_px`` seed 001's parallax
    error ``sigma_p`` (eq. 7, px); ``image_sigma_px`` the image position error across the ray (px);
    ``floor_m`` an absolute standard deviation added to every point (m; pose errors between the epochs
    where the landmarks were born, ``klt-pnp``); ``chi2_gate`` the one-degree-of-freedom chi-square bound of
    a pair (9.0: 3 sigma); ``max_violation_fraction`` the violated fraction above which a landmark is
    flagged; ``min_points`` fewer landmarks than this are not tested (all kept); ``seed`` of the partner
    stream."""

    enabled: bool = False
    partners: int = 24
    partner_quantile: float = 0.25
    disparity_sigma_px: float = 0.2
    image_sigma_px: float = 0.5
    floor_m: float = 0.01
    chi2_gate: float = 9.0
    max_violation_fraction: float = 0.3
    min_points: int = 12
    seed: int = 0

    def __post_init__(self):
        checks = {"partners": self.partners >= 1, "partner_quantile": 0 < self.partner_quantile <= 1,
                  "disparity_sigma_px": self.disparity_sigma_px > 0,
                  "image_sigma_px": self.image_sigma_px >= 0, "floor_m": self.floor_m >= 0,
                  "chi2_gate": self.chi2_gate > 0, "max_violation_fraction": 0 <= self.max_violation_fraction <= 1,
                  "min_points": self.min_points >= 3}
        for name, good in checks.items():
            if not good:
                raise VoError(f"RigidityConfig.{name}: invalid value {getattr(self, name)!r} (partners >= 1, "
                              "sigmas > 0, floor_m >= 0, chi2_gate > 0, 0 <= max_violation_fraction <= 1, "
                              "min_points >= 3)")

    @classmethod
    def from_option(cls, value, where: str = "rigidity") -> "RigidityConfig":
        """An estimator's ``rigidity`` option -> :class:`RigidityConfig`: None (defaults), a config, a bool
        (``enabled``) or a mapping of field names (``--opt 'rigidity={enabled: true}'``)."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        if isinstance(value, bool):
            return cls(enabled=value)
        if not isinstance(value, dict):
            raise VoError(f"{where}: {value!r}; expected a mapping of RigidityConfig fields, e.g. {{enabled: true}}")
        known = {f.name for f in fields(cls)}
        bad = sorted(set(value) - known)
        if bad:
            raise VoError(f"{where}: unknown field(s) {bad}; valid: {sorted(known)}")
        try:
            return cls(**value)
        except TypeError as e:
            raise VoError(f"{where}: {e}") from None


def stereo_covariances(p: np.ndarray, centres: np.ndarray, focal: float, baseline: float,
                       config: RigidityConfig) -> np.ndarray:
    """(N,3,3) covariances of stereo points ``p`` (N,3) seen from ``centres`` (N,3) or (3,) (same frame):
    seed 001 eq. 7 along the ray, ``sigma_r = r^2 sigma_p / (b f)``, and ``r sigma_px / f`` across it
    (eq. 8's bearing term), plus ``floor_m^2`` on every axis. ``focal`` px, ``baseline`` m."""
    ray = np.asarray(p, float) - np.asarray(centres, float)
    r = np.maximum(np.linalg.norm(ray, axis=1), 1e-9)
    u = ray / r[:, None]
    s_r = r ** 2 * config.disparity_sigma_px / (baseline * focal)
    s_t = r * config.image_sigma_px / focal
    uu = u[:, :, None] * u[:, None, :]
    return ((s_r ** 2 - s_t ** 2)[:, None, None] * uu + (s_t ** 2 + config.floor_m ** 2)[:, None, None] * np.eye(3))


def violation_fractions(p_a: np.ndarray, p_b: np.ndarray, cov_a: np.ndarray, cov_b: np.ndarray,
                        config: RigidityConfig, rng: np.random.Generator) -> np.ndarray:
    """(N,) fraction of each landmark's partners whose distance broke the invariance (module docstring),
    counted over the partners the first round did not flag. ``p_a``, ``p_b`` (N,3) the landmarks at the two
    epochs, ``cov_a``, ``cov_b`` (N,3,3) their covariances; N >= 2."""
    n = len(p_a)
    k = min(config.partners, n - 1)
    sig = np.sqrt(np.trace(cov_a, axis1=1, axis2=2))              # (N,) size of each point's error at epoch a
    order = np.argsort(sig, kind="stable")
    cut = np.quantile(sig, config.partner_quantile)
    m = np.searchsorted(sig[order], np.maximum(sig, cut), side="right")    # candidates: the m most precise
    j = order[np.minimum((rng.random((n, k)) * m[:, None]).astype(int), n - 1)]
    valid = j != np.arange(n)[:, None]                            # a draw of the landmark itself counts not
    i = np.broadcast_to(np.arange(n)[:, None], j.shape)
    d_a, d_b = p_a[i] - p_a[j], p_b[i] - p_b[j]                   # (N,K,3)
    l_a, l_b = np.linalg.norm(d_a, axis=2), np.linalg.norm(d_b, axis=2)
    u_a, u_b = d_a / np.maximum(l_a, 1e-9)[..., None], d_b / np.maximum(l_b, 1e-9)[..., None]
    s_a, s_b = cov_a[i] + cov_a[j], cov_b[i] + cov_b[j]            # (N,K,3,3)
    var = np.einsum("nki,nkij,nkj->nk", u_a, s_a, u_a) + np.einsum("nki,nkij,nkj->nk", u_b, s_b, u_b)
    bad = ((l_a - l_b) ** 2 > config.chi2_gate * var) & valid     # (N,K)
    frac = bad.sum(axis=1) / np.maximum(valid.sum(axis=1), 1)
    good = frac <= config.max_violation_fraction
    w = good[j] & valid                                           # second round: partners the first kept
    n_good = w.sum(axis=1)
    return np.where(n_good > 0, (bad & w).sum(axis=1) / np.maximum(n_good, 1), frac)


def rigid_subset(p_a: np.ndarray, c_a: np.ndarray, p_b: np.ndarray, c_b: np.ndarray, focal: float,
                 baseline: float, config: RigidityConfig, rng: np.random.Generator) -> np.ndarray:
    """(N,) bool: landmarks that keep the distance invariance with most partners (not flagged). ``p_a``
    (N,3) stereo points at epoch a seen from ``c_a`` ((N,3) or (3,), the same frame), ``p_b``, ``c_b``
    likewise at epoch b. All True when the test is off or fewer than ``min_points`` landmarks are given."""
    n = len(p_a)
    if not config.enabled or n < config.min_points:
        return np.ones(n, bool)
    cov_a = stereo_covariances(p_a, c_a, focal, baseline, config)
    cov_b = stereo_covariances(p_b, c_b, focal, baseline, config)
    return violation_fractions(np.asarray(p_a, float), np.asarray(p_b, float), cov_a, cov_b, config,
                               rng) <= config.max_violation_fraction


def refine_pose(T_c0_o: np.ndarray, p_o: np.ndarray, x_undist: np.ndarray, K: np.ndarray) -> np.ndarray:
    """``T_c0_o`` (4,4) refined by Levenberg-Marquardt (``cv2.solvePnPRefineLM``) on landmarks ``p_o`` (N,3)
    seen at undistorted pixels ``x_undist`` (N,2), started at ``T_c0_o``; N >= 4."""
    rvec, _ = cv2.Rodrigues(np.asarray(T_c0_o[:3, :3], float))
    tvec = np.asarray(T_c0_o[:3, 3], float).reshape(3, 1).copy()
    rvec, tvec = cv2.solvePnPRefineLM(np.asarray(p_o, np.float64), np.asarray(x_undist, np.float64),
                                      np.asarray(K, np.float64), None, rvec, tvec)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = cv2.Rodrigues(rvec)[0], tvec.reshape(3)
    return T
