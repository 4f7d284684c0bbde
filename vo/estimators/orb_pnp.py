"""Seed 003's descriptor stereo VO (``orb-pnp``; ``frontend="sift"`` too): descriptor matching of each left image
against the current keyframe's landmarks, 3-D-to-2-D PnP + RANSAC each frame; the current frame becomes the new
keyframe when seed 003's criterion fires on its PnP inliers. The frame loop, coasting and timings are those of
:class:`vo.estimators.stereo_pnp.StereoPnpEstimator`."""
from __future__ import annotations

import numpy as np

from vo.errors import EstimatorError
from vo.estimators.base import FrameResult
from vo.estimators.stereo_pnp import StereoPnpEstimator
from vo.estimators.stage_timing import timed
from vo.frontend.descriptors import DescriptorConfig, detect_and_describe, match_descriptors
from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig, is_keyframe
from vo.frontend.stereo import epipolar_mask


class OrbPnpEstimator(StereoPnpEstimator):
    """Descriptor stereo VO (seed 003's baseline). Options: ``frontend`` "orb" | "sift",
    ``descriptor_config`` (:class:`DescriptorConfig`), ``klt_config`` (grid / keyframe thresholds), ``pnp_config``,
    ``keyframe_criterion``: "inliers" (default; seed 003 section 6: the descriptor pipeline selects keyframes by
    key point number, i.e. PnP inliers < ``min_inliers``) or "grid" (also the empty-cell fraction; descriptor
    key points cluster on strong corners, so this makes nearly every frame a keyframe)."""

    name = "orb-pnp"

    def __init__(self, rig, frontend: str = "orb", descriptor_config: DescriptorConfig | None = None,
                 klt_config: KltConfig | None = None, keyframe_criterion: str = "inliers", **options):
        if frontend not in ("orb", "sift"):
            raise EstimatorError(f"orb-pnp: frontend {frontend!r} not supported; valid: orb, sift")
        if keyframe_criterion not in ("inliers", "grid"):
            raise EstimatorError(f"orb-pnp: keyframe_criterion {keyframe_criterion!r} unknown; valid: inliers, grid")
        self.keyframe_criterion = keyframe_criterion
        super().__init__(rig, **options)
        self.frontend = frontend
        self.desc_config = descriptor_config or DescriptorConfig()
        self.klt_config = KltConfig.from_option(klt_config, f"{self.name}.klt_config")
        cam = rig.cameras[0]
        self.grid = Grid(cam.width, cam.height, self.klt_config.cell)
        self.kf_p_o = np.zeros((0, 3))
        self.kf_desc = None

    def _initialize(self, left, right, timings, left_features=None) -> int:
        with timed(timings, "detect"):
            p_l, d_l = left_features or detect_and_describe(left, self.frontend, self.desc_config)
            p_r, d_r = detect_and_describe(right, self.frontend, self.desc_config)
        with timed(timings, "stereo"):
            ij = match_descriptors(d_l, d_r, self.frontend, self.desc_config)
            pl, pr = p_l[ij[:, 0]], p_r[ij[:, 1]]
            ok = epipolar_mask(self.rig, pl, pr, self.desc_config.epipolar_threshold_px) if len(ij) else np.zeros(0, bool)
            p_o, ok_t = self._triangulate_o(pl, pr)
            ok &= ok_t
            self.kf_p_o, self.kf_desc = p_o[ok], d_l[ij[ok, 0]]
        return int(ok.sum())

    def _step(self, t_ns, left, right, timings) -> FrameResult:
        with timed(timings, "detect"):
            p_l, d_l = detect_and_describe(left, self.frontend, self.desc_config)
        with timed(timings, "track"):
            ij = match_descriptors(self.kf_desc, d_l, self.frontend, self.desc_config)
        n_feat = len(ij)
        if n_feat < self.pnp_config.min_features:
            return self._fail(t_ns, "few_features", n_feat, 0, f"{n_feat} tracked < {self.pnp_config.min_features}")
        T_o_c0, inl = self._pnp(self.kf_p_o[ij[:, 0]], p_l[ij[:, 1]], timings)
        n_inl = int(inl.sum())
        if T_o_c0 is None or not self._accept_pose(T_o_c0):
            return self._fail(t_ns, "lost", n_feat, n_inl, f"PnP failed: {n_inl} inliers of {n_feat} matched")
        empty = self.grid.empty_fraction(p_l[ij[inl, 1]]) if self.keyframe_criterion == "grid" else 0.0
        if not is_keyframe(empty, n_inl, self.klt_config):
            return self._result(t_ns, "ok", n_feat, n_inl)
        n_new = self._initialize(left, right, timings, left_features=(p_l, d_l))
        if n_new < self.pnp_config.min_init_landmarks:
            self._need_init = True
        return self._result(t_ns, "keyframe", n_feat, n_inl, f"{n_new} landmarks")
