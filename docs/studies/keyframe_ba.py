"""Seed 003's keyframe optimization for ``klt-pnp``: a windowed stereo bundle adjustment, measured, not in the product.

Seed 003's pipeline optimizes on keyframes ("the optimization process only happens in key frames", Table 4)
and on every keyframe stereo-matches the *old* key points as well, "add[ing] key points calculated through
optical flow to old landmarks"; those observations only serve the optimization. The paper gives neither the
window nor the cost. This study builds one with gtsam (``KeyframeWindow``) and hands it to ``klt-pnp`` as its
``keyframe_adjuster`` collaborator:

* on every keyframe all tracks are stereo-matched; the poses ``T_o_c0`` of the last ``window`` keyframes and the
  landmarks they observe are adjusted by Levenberg-Marquardt (``iterations`` at most); then the new tracks
  are triangulated at the adjusted pose by the product's landmark source;
* each observation is a ``GenericProjectionFactorCal3_S2`` on undistorted pixels (the right one through
  ``body_P_sensor = T_c0_c1``), ``sigma_px`` and a Huber loss of threshold ``huber_k`` (whitened);
* the oldest keyframe of the window is held (a prior of ``FIXED_SIGMA``): the gauge;
* a landmark enters when it has a stereo observation in the window and is seen by at least two of its
  keyframes, unless rejected as moving: on every keyframe its stereo point (placed at the keyframe's pose) is
  compared with its first one by a chi-square test (``chi2_gate``, 3 dof) on the sum of their first-order
  triangulation covariances (pixel noise ``stereo_sigma_px``); a rejected landmark leaves the PnP as well.
  Without the test a car creeping ahead while the vehicle waits stays within each frame's 2-px PnP gate,
  is re-fitted window by window, and pulls the poses (urban-dynamic seed 0, 200 frames: 20.4 % drift).

Usage (prints what ``urban_dynamic_vo.py`` prints)::

    python docs/studies/keyframe_ba.py DATA [--window 5] [--chi2-gate 11.34] [--oracle] [--max-frames N]

Findings: ``docs/estimators.md``, "Keyframe bundle adjustment (study)".
"""
from __future__ import annotations

import argparse

from collections import deque
from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X

import urban_dynamic_vo as udv          # the sibling study: its runner and report
from rigs.typed_config import check_fields, knob
from vo.dataset.open import open_dataset
from vo.errorprop.triangulation import triangulation_covariance
from vo.errors import EstimatorError
from vo.frontend.klt import KltConfig, stereo_klt
from vo.frontend.stereo import triangulate, undistort_px

FIXED_SIGMA = 1e-6       # prior on the window's oldest keyframe (rad, m): the gauge


@dataclass(frozen=True)
class BaConfig:
    """``window`` keyframes adjusted together (0 or 1: no adjustment); ``sigma_px`` standard deviation of an
    observation (undistorted pixels); ``huber_k`` Huber threshold on the whitened residual;
    ``stereo_sigma_px`` pixel noise of the moving-landmark test and ``chi2_gate`` its threshold (3 dof; 11.34:
    99 %); ``iterations`` at most, of Levenberg-Marquardt per keyframe."""

    window: int = knob(0, ge=0)
    sigma_px: float = knob(1.0, gt=0)
    huber_k: float = knob(1.345, gt=0)
    stereo_sigma_px: float = knob(1.0, gt=0)
    chi2_gate: float = knob(11.34, gt=0)
    iterations: int = knob(10, ge=1)

    def __post_init__(self):
        check_fields(self, EstimatorError, "ba.")


@dataclass
class Keyframe:
    """One keyframe: its pose ``T_o_c0`` (4,4) and, per track id, the undistorted left pixel (2,) and, where
    the stereo match holds, the undistorted right pixel (2,)."""

    T_o_c0: np.ndarray
    left: dict
    right: dict


class KeyframeWindow:
    """The last ``config.window`` keyframes of a stereo rig ``rig``."""

    def __init__(self, rig, config: BaConfig, klt_config: KltConfig = KltConfig()):
        self.config, self.rig, self.klt_config = config, rig, klt_config
        c0, c1 = rig.cameras[0], rig.cameras[1]
        self.cams = (c0, c1)
        self.cal = [gtsam.Cal3_S2(c.K[0, 0], c.K[1, 1], c.K[0, 1], c.K[0, 2], c.K[1, 2]) for c in (c0, c1)]
        self.P_c0_c1 = gtsam.Pose3(np.asarray(rig.T_c0_c1, float))
        self.noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(config.huber_k),
                                                    gtsam.noiseModel.Isotropic.Sigma(2, config.sigma_px))
        self.frames: deque = deque(maxlen=max(config.window, 1))
        self.birth: dict = {}          # track id -> (p_o (3,), cov (3,3)) of its first stereo point
        self.rejected: set = set()     # tracks whose stereo points disagree (moving): never adjusted

    @property
    def enabled(self) -> bool:
        return self.config.window >= 2

    def reset(self) -> None:
        self.frames.clear()
        self.birth.clear()
        self.rejected.clear()

    def _check_birth(self, T_o_c0: np.ndarray, points: dict) -> None:
        """Compare each track's stereo point ``points`` (id -> p_c0) with its first one (chi-square on the
        sum of their first-order covariances); a track that fails is rejected for good."""
        R, t = T_o_c0[:3, :3], T_o_c0[:3, 3]
        c0, c1 = self.cams
        for i, p_c0 in points.items():
            cov = R @ triangulation_covariance(c0.K, c1.K, self.rig.T_c0_c1, p_c0, self.config.stereo_sigma_px) @ R.T
            p_o = R @ p_c0 + t
            if i not in self.birth:
                self.birth[i] = (p_o, cov)
                continue
            p_b, cov_b = self.birth[i]
            d = p_o - p_b
            if float(d @ np.linalg.solve(cov + cov_b, d)) > self.config.chi2_gate:
                self.rejected.add(i)

    def add(self, T_o_c0: np.ndarray, ids: np.ndarray, px_left: np.ndarray, px_right: np.ndarray,
            right_ok: np.ndarray) -> None:
        """A new keyframe at ``T_o_c0`` with tracks ``ids`` (n,) at raw pixels ``px_left`` (n,2), their right
        matches ``px_right`` (n,2) where ``right_ok`` (n,) bool."""
        ul = undistort_px(px_left, self.cams[0])
        ur = undistort_px(px_right, self.cams[1])
        left = {int(i): ul[k] for k, i in enumerate(ids)}
        p_c0, ok = triangulate(self.rig, px_left, px_right, np.inf, np.inf)
        ok &= np.asarray(right_ok, bool)
        right = {int(i): ur[k] for k, i in enumerate(ids) if ok[k]}
        points = {int(i): p_c0[k] for k, i in enumerate(ids) if ok[k]}
        self.frames.append(Keyframe(np.asarray(T_o_c0, float).copy(), left, right))
        self._check_birth(np.asarray(T_o_c0, float), points)
        alive = set().union(*(kf.left for kf in self.frames))
        self.birth = {i: b for i, b in self.birth.items() if i in alive}
        self.rejected &= alive

    def _adjusted_ids(self, landmarks: dict) -> list:
        seen: dict = {}
        stereo: set = set()
        for kf in self.frames:
            for i in kf.left:
                seen[i] = seen.get(i, 0) + 1
            stereo.update(kf.right)
        return sorted(i for i, n in seen.items()
                      if n >= 2 and i in stereo and i in landmarks and i not in self.rejected)

    def graph(self, landmarks: dict, ids: list) -> tuple:
        """(factor graph, initial values) of the window over the landmarks ``ids``."""
        g, v = gtsam.NonlinearFactorGraph(), gtsam.Values()
        use = set(ids)
        for k, kf in enumerate(self.frames):
            v.insert(X(k), gtsam.Pose3(kf.T_o_c0))
            for i, uv in kf.left.items():
                if i in use:
                    g.add(gtsam.GenericProjectionFactorCal3_S2(uv, self.noise, X(k), L(i), self.cal[0]))
            for i, uv in kf.right.items():
                if i in use:
                    g.add(gtsam.GenericProjectionFactorCal3_S2(uv, self.noise, X(k), L(i), self.cal[1], self.P_c0_c1))
        g.add(gtsam.PriorFactorPose3(X(0), gtsam.Pose3(self.frames[0].T_o_c0),
                                     gtsam.noiseModel.Isotropic.Sigma(6, FIXED_SIGMA)))
        for i in ids:
            v.insert(L(i), gtsam.Point3(*landmarks[i]))
        return g, v

    def adjust(self, left, right, T_o_c0: np.ndarray, ids: np.ndarray, px_left: np.ndarray, landmarks: dict) -> tuple:
        """``klt-pnp``'s keyframe adjuster: stereo-match every track ``ids`` (n,) at raw left pixels ``px_left``
        (n,2) of the keyframe at ``T_o_c0`` (4,4), add it to the window, drop the moving tracks from
        ``landmarks`` (id -> p_o (3,)) and adjust; returns (pose (4,4), landmarks, rejected ids)."""
        if not self.enabled:                    # window 0 or 1: the product's klt-pnp exactly
            return T_o_c0, landmarks, set()
        px_right, ok = stereo_klt(left, right, px_left, self.rig, self.klt_config)
        self.add(T_o_c0, ids, px_left, px_right, ok)
        for i in self.rejected:
            landmarks.pop(i, None)
        return self.optimize(landmarks), landmarks, set(self.rejected)

    def optimize(self, landmarks: dict) -> np.ndarray:
        """Adjust the window; update the keyframe poses and ``landmarks`` in place; return the newest
        keyframe's pose (4,4). Without enough keyframes or landmarks, or if gtsam refuses the system,
        nothing changes."""
        newest = self.frames[-1].T_o_c0
        if not self.enabled or len(self.frames) < 2:
            return newest
        ids = self._adjusted_ids(landmarks)
        if len(ids) < 3:
            return newest
        g, v = self.graph(landmarks, ids)
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(self.config.iterations)
        try:
            res = gtsam.LevenbergMarquardtOptimizer(g, v, params).optimize()
        except RuntimeError:            # indeterminant system or cheirality: keep the PnP poses
            return newest
        for k, kf in enumerate(self.frames):
            kf.T_o_c0 = res.atPose3(X(k)).matrix()
        for i in ids:
            landmarks[i] = np.asarray(res.atPoint3(L(i)), float)
        return self.frames[-1].T_o_c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--window", type=int, default=5)
    ap.add_argument("--chi2-gate", type=float, default=11.34)
    ap.add_argument("--max-frames", type=int)
    ap.add_argument("--oracle", action="store_true", help="drop the features on moving actors before the PnP")
    a = ap.parse_args()
    cfg = BaConfig(window=a.window, chi2_gate=a.chi2_gate)
    window = KeyframeWindow(open_dataset(a.dataset).rig, cfg)
    udv.report(udv.run(a.dataset, "klt-pnp", a.max_frames, {"keyframe_adjuster": window}, a.oracle))


if __name__ == "__main__":
    main()
