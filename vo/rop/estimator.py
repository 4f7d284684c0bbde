"""``RopEstimator`` ("rop"): seed 000's stereo VO - four ROPs per epoch pair, ROP adjustment, chaining.

For each new stereo frame (images 3, 4) and the previous one (images 1, 2): match 1-3, 1-4, 2-3,
2-4, estimate each ROP (essential matrix, RANSAC), initial EOPs, two-step adjustment, then
``T_o_c0(k+1) = T_o_c0(k) @ T_c1_c3``. Covariance of ``[rotvec, position]`` of ``T_o_c0`` (left
perturbation) is propagated to first order: with ``R = R_o_c1``, ``p = t_c1_c3``,
``cov_new = A cov_old A^T + B cov_step B^T``, ``A = [[I, 0], [-skew(R p), I]]``,
``B = blockdiag(R, R)`` (steps are treated as independent; consecutive steps share an image, so
this is approximate). On failure (too few matches, degenerate geometry) the last pose is kept
(or extrapolated with the last good motion if ``constant_velocity``), never NaN, and the next
frame re-initialises from the current one.
"""
from __future__ import annotations

import time

import numpy as np

from vo.dataset.types import StereoFrame
from vo.errors import EstimatorError
from vo.estimators.base import Estimator, FrameResult
from vo.geometry import skew
from vo.rop import matching
from vo.rop.adjustment import AdjustmentConfig, adjust_rops
from vo.rop.initial import initial_eops
from vo.rop.relative import estimate_rop
from vo.rop.ropset import PAIRS, RopSet

COVS = ("apost", "apriori")


def propagate_cov(cov_old: np.ndarray, T_o_c1: np.ndarray, T_c1_c3: np.ndarray, cov_step: np.ndarray) -> np.ndarray:
    """(6,6) covariance of ``T_o_c3 = T_o_c1 @ T_c1_c3`` (first order, see the module docstring)."""
    R = T_o_c1[:3, :3]
    A = np.eye(6)
    A[3:, :3] = -skew(R @ T_c1_c3[:3, 3])
    B = np.zeros((6, 6))
    B[:3, :3] = B[3:, 3:] = R
    C = A @ cov_old @ A.T + B @ cov_step @ B.T
    return 0.5 * (C + C.T)


class RopEstimator(Estimator):
    """Options: ``frontend`` "klt"|"orb"|"sift" (default "orb"), ``max_features`` (1000),
    ``ransac_threshold_px`` (1.0), ``min_matches`` (30), ``seed`` (0, cv2 RANSAC),
    ``cov`` "apost"|"apriori", ``sigma_rot_deg`` / ``sigma_dir_deg`` (a-priori unit-weight ROP
    sigmas, default 0.05 / 0.1), ``constant_velocity`` (False)."""

    name = "rop"

    def __init__(self, rig, **options):
        super().__init__(rig, **options)
        known = {"frontend", "max_features", "ransac_threshold_px", "min_matches", "seed", "cov",
                 "sigma_rot_deg", "sigma_dir_deg", "constant_velocity"}
        bad = sorted(set(options) - known)
        if bad:
            raise EstimatorError(f"rop: unknown option(s) {bad}; valid: {', '.join(sorted(known))}")
        if not rig.is_stereo:
            raise EstimatorError(f"rop: rig {rig.name!r} has one camera; seed 000 needs a stereo rig")
        self.frontend = options.get("frontend", "orb")
        if self.frontend not in matching.KINDS:
            raise EstimatorError(f"rop.frontend: {self.frontend!r}; valid: {', '.join(matching.KINDS)}")
        self.cov_kind = options.get("cov", "apost")
        if self.cov_kind not in COVS:
            raise EstimatorError(f"rop.cov: {self.cov_kind!r}; valid: {', '.join(COVS)}")
        self.max_features = int(options.get("max_features", 1000))
        self.threshold_px = float(options.get("ransac_threshold_px", 1.0))
        self.min_matches = int(options.get("min_matches", 30))
        self.seed = int(options.get("seed", 0))
        self.constant_velocity = bool(options.get("constant_velocity", False))
        self.config = AdjustmentConfig(sigma_rot_rad=np.radians(float(options.get("sigma_rot_deg", 0.05))),
                                       sigma_dir_rad=np.radians(float(options.get("sigma_dir_deg", 0.1))))
        self.cams = rig.cameras[:2]
        self.T_c1_c2 = rig.T_c0_c1
        self._prev = None            # (frame, features_left, features_right)
        self.T_o_c0 = np.eye(4)
        self.cov = np.zeros((6, 6))
        self._last_motion = np.eye(4)
        self._lost = False

    def _rops(self, prev, cur, timings):
        """The four ROPs (pair -> RopMeasurement) and the smallest match count."""
        t0 = time.perf_counter()
        imgs = {1: prev[0].left, 2: prev[0].right, 3: cur[0].left, 4: cur[0].right}
        feats = {1: prev[1], 2: prev[2], 3: cur[1], 4: cur[2]}
        matches = {p: matching.match(feats[int(p[0])], feats[int(p[1])], imgs[int(p[0])], imgs[int(p[1])],
                                     self.frontend) for p in PAIRS}
        t1 = time.perf_counter()
        rops = {}
        for p, (a, b) in matches.items():
            ci, cj = self.cams[(int(p[0]) - 1) % 2], self.cams[(int(p[1]) - 1) % 2]
            if len(a) >= self.min_matches:
                rops[p] = estimate_rop(a, b, ci.K, ci.dist_coeffs, cj.K, cj.dist_coeffs, seed=self.seed,
                                       ransac_threshold_px=self.threshold_px)
        timings["matching"] += (t1 - t0) * 1e3
        timings["essential"] = (time.perf_counter() - t1) * 1e3
        return rops, min(len(a) for a, _ in matches.values())

    def _features(self, frame):
        return (frame, matching.detect(frame.left, self.frontend, self.max_features),
                matching.detect(frame.right, self.frontend, self.max_features))

    def _fail(self, frame, cur, status, n_matches, n_inl, msg, timings) -> FrameResult:
        if self.constant_velocity:
            self.T_o_c0 = self.T_o_c0 @ self._last_motion
        self._prev, self._lost = cur, True
        msg += "; pose held" + (" (constant velocity)" if self.constant_velocity else "") + \
               ", re-initialising from this frame"
        return FrameResult(frame.t_ns, self.T_o_c0.copy(), status, n_matches, n_inl, self.cov.copy(), msg, timings)

    def process(self, frame: StereoFrame) -> FrameResult:
        timings = {"matching": 0.0, "essential": 0.0, "initial": 0.0, "adjust": 0.0}
        t0 = time.perf_counter()
        cur = self._features(frame)
        timings["matching"] = (time.perf_counter() - t0) * 1e3
        if self._prev is None:
            self._prev = cur
            return FrameResult(frame.t_ns, self.T_o_c0.copy(), "init", len(cur[1][0]), 0, self.cov.copy(),
                               "first frame defines O", timings)
        rops, n_matches = self._rops(self._prev, cur, timings)
        ropset = RopSet(rops, self.T_c1_c2)
        n_inl = min((r.n_inliers for r in rops.values() if r.ok), default=0)
        if len(ropset.ok_pairs) < 3:
            return self._fail(frame, cur, "few_features", n_matches, n_inl,
                              f"{len(ropset.ok_pairs)} of 4 ROPs usable (min matches {n_matches} "
                              f"< {self.min_matches}?: texture-poor view?)", timings)
        t1 = time.perf_counter()
        init = initial_eops(ropset)
        t2 = time.perf_counter()
        res = adjust_rops(ropset, init, self.config)
        timings["initial"], timings["adjust"] = (t2 - t1) * 1e3, (time.perf_counter() - t2) * 1e3
        cov_step = res.cov_apriori if self.cov_kind == "apriori" else res.cov_apost
        if res.degenerate or cov_step is None or not np.all(np.isfinite(res.T_c1_c3)):
            return self._fail(frame, cur, "lost", n_matches, n_inl, f"degenerate ROP geometry: {res.message}", timings)
        self.cov = propagate_cov(self.cov, self.T_o_c0, res.T_c1_c3, cov_step)
        self.T_o_c0 = self.T_o_c0 @ res.T_c1_c3
        self._last_motion, self._prev = res.T_c1_c3, cur
        status, msg = ("reinit", "re-initialised after a failed frame") if self._lost else ("ok", "")
        self._lost = False
        return FrameResult(frame.t_ns, self.T_o_c0.copy(), status, n_matches, n_inl, self.cov.copy(), msg, timings)
