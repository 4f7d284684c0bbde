"""Oracle tracks: ``rop`` with its KLT track *positions* replaced by exact ones (docs/consistency.md).

The KLT four-view front-end (:class:`vo.rop.tracks.KltFourView`) still decides which tracks exist
(detection, survival, keyframes); after each of its ``keyframe`` / ``track`` calls the positions are
replaced by the exact projections (rig model with distortion) of the 3-D point seen at ``p1`` in the
keyframe's left image: rendered depth (a plane fitted to the inverse depth of the 5x5 window, exact
on planar surfaces; depth discontinuities dropped) moved through the true camera poses. Optional iid
Gaussian pixel noise on all four views is the first-order error model's own assumption, so the Monte
Carlo NEES of the back-end (four ROPs, adjustment, chaining, covariance propagation) can be checked
on its own, apart from the front-end's errors on rendered images.

Needs a dataset with depth and ground truth (``GenerateConfig(depth=True)``). Validation only: a
real estimator never sees depth or truth.
"""
from __future__ import annotations

import numpy as np

from sim.errors import SimError
from sim.app.validation.exact_points import backproject, local_depth, project
from rigs.geometry import inv_T
from vo.estimators.runner import run_estimator
from vo.frontend.klt import KltConfig
from vo.rop.rop_config import RopConfig
from vo.rop.tracks import FourView, KltFourView

VIEWS = ("p2", "p3", "p4")          # positions an oracle can replace (p1 is the detection itself)


class OracleFourView(KltFourView):
    """:class:`KltFourView` whose positions ``exact`` (subset of :data:`VIEWS`; ``p1`` too when noise is
    on) are exact + ``noise_px`` iid Gaussian noise from ``rng``. Set :attr:`k` (frame index) before
    each ``keyframe`` / ``track`` call; ``record`` (a list) collects KLT vs exact positions if given."""

    def __init__(self, rig, dataset, noise_px: float = 0.0, rng=None, exact=VIEWS, record=None, config=None,
                 refine: str = "translation"):
        super().__init__(rig, config or KltConfig(), refine)
        bad = sorted(set(exact) - set(VIEWS))
        if bad:
            raise SimError(f"oracle tracks: unknown view(s) {bad}; valid: {', '.join(VIEWS)}")
        self.dataset, self.exact, self.record = dataset, frozenset(exact), record
        self.noise_px, self.rng = float(noise_px), rng if rng is not None else np.random.default_rng(0)
        self.T_w_c0 = dataset.groundtruth_cam0().T
        self.T_c0_c1 = inv_T(rig.cameras[0].T_b_c_array) @ rig.cameras[1].T_b_c_array
        self.k = 0
        self._X = {}                 # p1 (as a tuple) -> X_w of the track

    def _noisy(self, p):
        return p if self.noise_px <= 0 else p + self.noise_px * self.rng.standard_normal(p.shape)

    def _poses(self):
        T_w_c0 = self.T_w_c0[self.k]
        return T_w_c0, T_w_c0 @ self.T_c0_c1

    def keyframe(self, left, right, timings: dict, keep_tracks: bool = True) -> int:
        super().keyframe(left, right, timings, keep_tracks)
        v, (T_w_c0, T_w_c1) = self.view, self._poses()
        z, ok = local_depth(np.asarray(self.dataset.depth(self.k, 0), float), v.p1)
        X_w = backproject(self.cams[0], v.p1, z) @ T_w_c0[:3, :3].T + T_w_c0[:3, 3]
        p2, front = project(self.cams[1], T_w_c1, X_w)
        ok &= front
        if self.record is not None:
            self.record.append(dict(k=self.k, kf=True, p1=v.p1, p2_klt=v.p2, p2=p2, ok=ok))
        p1, X_w = self._noisy(v.p1[ok]), X_w[ok]
        p2 = self._noisy(p2[ok]) if "p2" in self.exact else v.p2[ok]
        x1, x2 = self.normalize(p1, 0), self.normalize(p2, 1)
        self.view = FourView(p1, p2, p1.copy(), p2.copy(), x1, x2, x1.copy(), x2.copy(), np.ones(len(p1), bool),
                             ids=v.ids[ok])
        self._X = {tuple(p): X for p, X in zip(p1, X_w)}
        return len(p1)

    def track(self, left, right, timings: dict, predict=None) -> FourView:
        v = super().track(left, right, timings, predict)
        T_w_c0, T_w_c1 = self._poses()
        X_w = np.array([self._X[tuple(p)] for p in v.p1]).reshape(-1, 3)
        p3, p4 = project(self.cams[0], T_w_c0, X_w)[0], project(self.cams[1], T_w_c1, X_w)[0]
        if self.record is not None:
            self.record.append(dict(k=self.k, kf=False, p1=v.p1, p3_klt=v.p3, p3=p3, p4_klt=v.p4, p4=p4, ok4=v.ok4))
        if "p3" in self.exact:
            v.p3 = self._noisy(p3)
            v.x3 = self.normalize(v.p3, 0)
        if "p4" in self.exact:
            v.p4 = np.where(v.ok4[:, None], self._noisy(p4), v.p4)
            v.x4 = np.zeros_like(v.p4)
            v.x4[v.ok4] = self.normalize(v.p4[v.ok4], 1)
        self.view = v
        return v


def run_oracle(dataset, options: dict | None = None, noise_px: float = 0.0, seed: int = 0, exact=VIEWS,
               max_frames: int | None = None, record=None, images=None) -> list:
    """``rop`` (KLT front-end) on ``dataset`` with :class:`OracleFourView` tracks -> list of FrameResult.

    ``images`` (default ``dataset``) is where the frames come from: pass a noisy view of the same
    dataset to keep KLT's positions for the views not in ``exact``."""
    options = dict(options or {})
    cfg = RopConfig.from_options(options)
    if cfg.frontend != "klt":
        raise SimError(f"oracle tracks: rop.frontend must be 'klt', got {cfg.frontend!r}")
    oracle = OracleFourView(dataset.rig, dataset, noise_px, np.random.default_rng([int(seed), 0x0AC1E]), exact,
                            record, config=cfg.klt_config, refine=cfg.klt_refine)

    def at_frame(frame):
        oracle.k = frame.index

    return run_estimator("rop", images or dataset, {**options, "tracker": oracle}, progress=False,
                         max_frames=max_frames, seed=seed, before_frame=at_frame).frames
