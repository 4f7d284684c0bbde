"""Cross-site localisation accuracy model (seed 001, eq. 9-13) and its Monte-Carlo check.

Model, as the paper sets it up: tie points (landmarks) are measured in stereo from the previous
site (range error eq. 7, azimuth error ``sigma_theta``, planar covariance eq. 8). A 2-D similarity
``X = a x - b y + c, Y = b x + a y + d`` (eq. 9) maps the current site's coordinates ``(x, y)`` of
the tie points onto the previous site's ``(X, Y)``; least squares (eq. 10) with the tie-point
covariance ``M_c^p`` as weights gives the parameter covariance ``M_c^T = (A^T (M_c^p)^-1 A)^-1``
(eq. 11); the new site position ``(X_N, Y_N) = C [a b c d]^T`` with ``C = [[x_p, -y_p, 1, 0],
[y_p, x_p, 0, 1]]`` (eq. 12) has covariance ``M_p = C M_c^T C^T`` (eq. 13).

Interpretation (the paper leaves it implicit): the observations ``L`` are the tie points as seen
from the previous site; the current site's coordinates enter ``A`` as error-free coefficients.
The accuracy is reported as ``sqrt(trace(M_p))`` over the distance between the sites. With the
paper's numbers this gives 1.06% (forward-forward; printed 1.05%) and 0.375% (forward-backward;
printed 0.38%).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import block_diag

from rigs.config_io import read_yaml_file
from rigs.typed_config import load_dataclass
from vo.errorprop.range import planar_covariance, range_sigma
from vo.errors import VoError


@dataclass(frozen=True)
class CrossSiteConfig:
    """Camera and layout of a cross-site localisation (metres, pixels)."""

    f_px: float = 1189.0
    baseline_m: float = 0.27
    sigma_p_px: float = 1.0 / 3.0
    sigma_theta_px: float = 3.0          # sigma_theta = atan(sigma_theta_px / f)
    previous_site: tuple = (0.0, 0.0)
    current_site: tuple = (10.0, 0.0)
    landmarks: tuple = ((13.0, 1.5), (13.0, -1.5), (16.0, 1.5), (16.0, -1.5))

    def __post_init__(self):
        for name in ("f_px", "baseline_m", "sigma_p_px", "sigma_theta_px"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise VoError(f"cross-site config: {name} must be a positive number, got {v!r}")
        lm = np.asarray(self.landmarks, dtype=float)
        if lm.ndim != 2 or lm.shape[1] != 2 or lm.shape[0] < 2:
            raise VoError(f"cross-site config: landmarks must be at least two (x, y) points, got shape {lm.shape}")
        object.__setattr__(self, "landmarks", tuple(map(tuple, lm.tolist())))
        object.__setattr__(self, "previous_site", tuple(float(v) for v in self.previous_site))
        object.__setattr__(self, "current_site", tuple(float(v) for v in self.current_site))

    @property
    def sigma_theta(self) -> float:
        return float(np.arctan(self.sigma_theta_px / self.f_px))

    @property
    def distance(self) -> float:
        return float(np.hypot(*(np.subtract(self.current_site, self.previous_site))))


CROSS_SITE_PRESETS = {
    "paper-ff": CrossSiteConfig(),
    "paper-fb": CrossSiteConfig(landmarks=((3.5, 1.5), (3.5, -1.5), (6.5, 1.5), (6.5, -1.5))),
}


def load_cross_site_config(path) -> CrossSiteConfig:
    """YAML whose keys are :class:`CrossSiteConfig` field names, every one of them: a layout file
    that left a field out would silently get the paper's value, so missing fields are an error
    naming them all (the paper's layouts are :data:`CROSS_SITE_PRESETS`)."""
    import dataclasses
    names = [f.name for f in dataclasses.fields(CrossSiteConfig)]
    data = read_yaml_file(path, VoError)
    if isinstance(data, dict) and set(data) <= set(names):
        missing = [n for n in names if n not in data]
        if missing:
            raise VoError(f"{path}: missing field(s) {', '.join(missing)}; a cross-site file gives every "
                          f"field: {', '.join(names)}")
    return load_dataclass(CrossSiteConfig, path, VoError)


@dataclass(frozen=True)
class CrossSiteResult:
    M_T: np.ndarray = field(repr=False)      # (4,4) covariance of (a, b, c, d)
    M_p: np.ndarray = field(repr=False)      # (2,2) covariance of the new site position
    sigma_pos_m: float                       # sqrt(trace(M_p))
    distance_m: float
    accuracy_percent: float

    def to_dict(self) -> dict:
        return {"M_T": self.M_T.tolist(), "M_p": self.M_p.tolist(), "sigma_pos_m": self.sigma_pos_m,
                "distance_m": self.distance_m, "accuracy_percent": self.accuracy_percent}


def tie_point_covariance(site, landmark, cfg: CrossSiteConfig) -> np.ndarray:
    """(2,2) covariance of a landmark position measured in stereo from ``site`` (eq. 7, 8)."""
    d = np.subtract(landmark, site)
    r, theta = float(np.hypot(*d)), float(np.arctan2(d[1], d[0]))
    return planar_covariance(r, theta, float(range_sigma(r, cfg.baseline_m, cfg.f_px, cfg.sigma_p_px)),
                             cfg.sigma_theta)


def design_matrix(points_xy: np.ndarray) -> np.ndarray:
    """Eq. 9/10: (2N,4) coefficients of (a, b, c, d) for points (N,2)."""
    A = np.zeros((2 * len(points_xy), 4))
    A[0::2] = np.c_[points_xy[:, 0], -points_xy[:, 1], np.ones(len(points_xy)), np.zeros(len(points_xy))]
    A[1::2] = np.c_[points_xy[:, 1], points_xy[:, 0], np.zeros(len(points_xy)), np.ones(len(points_xy))]
    return A


def cross_site_accuracy(cfg: CrossSiteConfig) -> CrossSiteResult:
    """Analytic accuracy of the new site position (eq. 11-13)."""
    lm = np.asarray(cfg.landmarks)
    A = design_matrix(lm)
    M_cp = block_diag(*[tie_point_covariance(cfg.previous_site, p, cfg) for p in lm])
    M_T = np.linalg.inv(A.T @ np.linalg.solve(M_cp, A))
    xp, yp = cfg.current_site
    C = np.array([[xp, -yp, 1, 0], [yp, xp, 0, 1]])
    M_p = C @ M_T @ C.T
    sigma = float(np.sqrt(np.trace(M_p)))
    return CrossSiteResult(M_T, M_p, sigma, cfg.distance, 100.0 * sigma / cfg.distance)


def cross_site_monte_carlo(cfg: CrossSiteConfig, n: int, rng: np.random.Generator) -> CrossSiteResult:
    """Simulate the same model: draw range/azimuth errors of every tie point seen from the previous
    site, fit the similarity by weighted least squares, transform the current site; return the
    sample covariance of the new site position in the same result type."""
    lm = np.asarray(cfg.landmarks)
    A = design_matrix(lm)
    M_cp = block_diag(*[tie_point_covariance(cfg.previous_site, p, cfg) for p in lm])
    W = np.linalg.inv(M_cp)
    solve = np.linalg.solve(A.T @ W @ A, A.T @ W)            # (4, 2N)
    d = lm - np.asarray(cfg.previous_site)
    r, theta = np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0])
    sr = range_sigma(r, cfg.baseline_m, cfg.f_px, cfg.sigma_p_px)
    r_s = r + sr * rng.standard_normal((n, len(lm)))
    th_s = theta + cfg.sigma_theta * rng.standard_normal((n, len(lm)))
    obs = np.stack([r_s * np.cos(th_s), r_s * np.sin(th_s)], axis=-1) + np.asarray(cfg.previous_site)
    params = obs.reshape(n, -1) @ solve.T                     # (n, 4)
    xp, yp = cfg.current_site
    C = np.array([[xp, -yp, 1, 0], [yp, xp, 0, 1]])
    sites = params @ C.T
    M_p = np.cov(sites.T)
    sigma = float(np.sqrt(np.trace(M_p)))
    return CrossSiteResult(np.cov(params.T), M_p, sigma, cfg.distance, 100.0 * sigma / cfg.distance)
