"""Study: ``klt-pnp``'s landmark depths refined from the tracks' parallax (a per-landmark inverse-depth filter).

``klt-pnp`` keeps each landmark at its birth keyframe's stereo triangulation. A corner on an occlusion boundary
(a T-junction) gets a stereo disparity between the two surfaces' (the 21x21 window straddles both), and such
landmarks' tracks then move, against the estimated poses, as if their points lay farther than their stereo depth
(urban-dynamic seeds 0 and 4: a mean signed residual along the parallax direction of +0.1-0.7 px after 2-5 frames,
against +0.01-0.06 px for plane landmarks; ``docs/studies/track_residual_labels.py``); their bias turns the pose
(docs/estimators.md, "Cause of klt-pnp's remaining urban drift"). One landmark's bias is below its track noise, so
no per-landmark statistic separates them (ROC areas 0.54-0.78), but the temporal baseline, metres after a few
frames against the stereo pair's 0.5 m, measures each landmark's depth again. Results (the drift does not fall):
docs/estimators.md, "Depth-edge landmarks across frames".

Each landmark is a point on its birth ray, ``p_o = c + d / rho`` (``c`` the birth camera centre, ``d`` the birth
bearing with unit depth, both in the odometry frame; ``rho`` inverse depth). Its prior is the stereo point with
``sigma_rho = disparity_sigma_px / (f b)`` (the disparity error, seed 001 eq. 7 in inverse depth). Each later frame
whose pose the estimator accepted observes the landmark's track ``u`` (distorted pixels): ``u = h(rho) + n``,
``h`` the projection at that pose, ``n ~ N(0, image_sigma_px^2 I)``. The linearised Kalman update of a scalar
state with a 2-D measurement (``H = dh/drho``, numerically):

    info = 1 / var + |H|^2 / s^2,    rho += (H . r / s^2) / info,    var = 1 / info,    r = u - h(rho)

is applied unless the innovation fails a chi-square gate (two degrees of freedom, ``chi2_gate``): a track that
does not fit a static point at any depth (a moving actor, a sliding junction across the parallax direction) keeps
its landmark. The poses are taken as exact (they come from the same landmarks, so the updates are correlated and
the variance optimistic; ``image_sigma_px`` above the measured KLT track noise, 0.33-0.40 px, tempers it).

The filter keeps its state per landmark id and re-initialises a landmark from its current position whenever the
estimator moved it (disparity-offset correction, re-chained start-up): it only ever refines what it wrote.

Modes (``--mode``): ``update`` writes the refined positions into the estimator's map after each frame (through the
runner's ``on_frame`` hook: the study rewrites the map from outside the estimator, which the product never does);
``test`` leaves the map alone, runs the filter in the shadow and demotes a landmark whose refined inverse depth
departs from its stereo one by more than ``chi2_gate`` times the variance of that difference (``var_stereo -
var_filter``; one degree of freedom) by moving it to half its depth, so that the estimator's 2 px track gate drops it
on the next frame; ``anti`` applies the update with the opposite sign (``rho -= ...``: an unstable update that
pushes every landmark with a persistent parallax residual out through the track gate; a control, not an
estimator). Prints the end drift (first-pose alignment) and the filter's CPU time per frame::

    python docs/studies/landmark_depth_filter.py DATA [--mode update|test|anti|off] [--max-frames N]
"""
from __future__ import annotations

from dataclasses import dataclass

import argparse
import time

import numpy as np

from rigs.geometry import inv_T, transform_points
from rigs.geometry.pinhole import project
from vo.dataset import open_dataset
from vo.errors import VoError
from vo.estimators.runner import run_estimator


@dataclass(frozen=True)
class DepthFilterConfig:
    """``enabled`` refine landmark depths; ``disparity_sigma_px`` the stereo disparity error of the prior (px);
    ``image_sigma_px`` the track's pixel error per axis (px); ``chi2_gate`` the innovation gate (two degrees of
    freedom; 9.21: 99 %); ``min_rho`` inverse depths below it (1/m; points beyond 1 km) are not updated."""

    enabled: bool = True
    disparity_sigma_px: float = 0.1
    image_sigma_px: float = 0.5
    chi2_gate: float = 9.21
    min_rho: float = 1e-3

    def __post_init__(self):
        for name in ("disparity_sigma_px", "image_sigma_px", "chi2_gate", "min_rho"):
            if not getattr(self, name) > 0:
                raise VoError(f"DepthFilterConfig.{name}: must be > 0, got {getattr(self, name)!r}")


class DepthFilter:
    """Per-landmark inverse-depth filter (module docstring). ``camera`` the left camera (``K``, ``dist``);
    ``fb`` focal length x baseline (px m)."""

    def __init__(self, config: DepthFilterConfig, camera, fb: float, mode: str = "update"):
        self.config, self.camera, self.fb, self.mode = config, camera, float(fb), mode
        self.demoted = 0
        self._rho0: dict = {}      # id -> stereo inverse depth (mode test)
        self._shadow: dict = {}    # id -> refined inverse depth (mode test)
        self._var: dict = {}       # id -> inverse-depth variance (1/m^2)
        self._wrote: dict = {}     # id -> p_o (3,) the filter last wrote (or found at initialisation)

    def update(self, T_o_c0: np.ndarray, ids: np.ndarray, px: np.ndarray, landmarks: dict, rays: dict) -> int:
        """Refine ``landmarks`` ({id: p_o (3,)}, changed in place) of the tracked ``ids`` (N,) at pixels ``px``
        (N,2) seen from the accepted pose ``T_o_c0`` (4,4); ``rays`` {id: (_, birth centre c_o (3,), birth bearing
        d_o (3,))}, ``klt-pnp``'s ``near``. Returns the number of landmarks updated (0 when disabled)."""
        if not self.config.enabled:
            return 0
        self._var = {i: v for i, v in self._var.items() if i in landmarks}
        self._rho0 = {i: v for i, v in self._rho0.items() if i in landmarks}
        self._shadow = {i: v for i, v in self._shadow.items() if i in landmarks}
        self._wrote = {i: p for i, p in self._wrote.items() if i in landmarks}
        idx = [(k, int(i)) for k, i in enumerate(ids) if int(i) in landmarks]
        if not idx:
            return 0
        rows, keys = np.array([k for k, _ in idx]), [i for _, i in idx]
        p_o = np.array([landmarks[i] for i in keys])
        c_o = np.array([rays[i][1] for i in keys])
        d_o = np.array([rays[i][2] for i in keys])
        rho = np.einsum("ij,ij->i", d_o, d_o) / np.einsum("ij,ij->i", p_o - c_o, d_o)
        prior = (self.config.disparity_sigma_px / self.fb) ** 2
        known = np.array([i in self._var and np.array_equal(self._wrote[i], landmarks[i]) for i in keys], bool)
        for i, p, q in zip(np.asarray(keys)[~known], p_o[~known], rho[~known]):
            self._var[int(i)], self._wrote[int(i)], self._rho0[int(i)] = prior, p, q
        if not known.any():
            return 0
        if self.mode == "test":       # the shadow state: the map keeps the stereo point
            rho = np.array([self._shadow.get(i, q) for i, q in zip(keys, rho)])
        k = known & (rho > self.config.min_rho)
        T_c_o = inv_T(T_o_c0)
        h = self._project(T_c_o, c_o[k] + d_o[k] / rho[k, None])
        eps = 1e-3
        H = (self._project(T_c_o, c_o[k] + d_o[k] / (rho[k, None] * (1.0 + eps))) - h) / (rho[k, None] * eps)
        if self.mode == "anti":
            H = -H
        r = px[rows[k]] - h
        var = np.array([self._var[i] for i in np.asarray(keys)[k]])
        s2 = self.config.image_sigma_px ** 2
        HH, Hr = np.einsum("ij,ij->i", H, H), np.einsum("ij,ij->i", H, r)
        chi2 = (np.einsum("ij,ij->i", r, r) - Hr ** 2 * var / (s2 + var * HH)) / s2   # r^T (s2 I + var H H^T)^-1 r
        info = 1.0 / var + HH / s2
        rho_new = rho[k] + Hr / s2 / info
        good = (chi2 < self.config.chi2_gate) & (rho_new > self.config.min_rho)
        for i, c, d, q, w in zip(np.asarray(keys)[k][good], c_o[k][good], d_o[k][good], rho_new[good], info[good]):
            i = int(i)
            self._var[i] = 1.0 / w
            if self.mode != "test":
                landmarks[i] = self._wrote[i] = c + d / q
                continue
            self._shadow[i] = q
            if (q - self._rho0[i]) ** 2 > self.config.chi2_gate * max(prior - 1.0 / w, 1e-12):
                landmarks[i] = self._wrote[i] = c + d / (2.0 * self._rho0[i])     # demoted: half its depth
                self.demoted += 1
        return int(good.sum())

    def _project(self, T_c_o: np.ndarray, p_o: np.ndarray) -> np.ndarray:
        return project(transform_points(T_c_o, p_o), self.camera.K, self.camera.dist)



def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--mode", choices=("update", "test", "anti", "off"), default="update")
    ap.add_argument("--max-frames", type=int)
    ap.add_argument("--image-sigma-px", type=float, default=DepthFilterConfig.image_sigma_px)
    a = ap.parse_args()
    ds = open_dataset(a.dataset)
    n = len(ds) if a.max_frames is None else min(a.max_frames, len(ds))
    cam = ds.rig.cameras[0]
    filt = DepthFilter(DepthFilterConfig(enabled=a.mode != "off", image_sigma_px=a.image_sigma_px), cam,
                       float(cam.K[0, 0]) * float(np.linalg.norm(ds.rig.T_c0_c1[:3, 3])), a.mode)
    cur = {"T": np.eye(4), "cpu": 0.0, "n": 0}

    def after(frame, result, est):
        cur["T"] = result.T_o_c0.copy()
        if result.pose_class == "ok":
            t0 = time.process_time()
            cur["n"] += filt.update(est.T_o_c0, est.tracker.ids, est.tracker.pts, est.landmarks, est.near)
            cur["cpu"] += time.process_time() - t0

    run_estimator("klt-pnp", ds, {}, progress=False, max_frames=n, on_frame=after)
    T_w_c = ds.groundtruth_cam0().T[:n]
    path = float(np.sum(np.linalg.norm(np.diff(T_w_c[:, :3, 3], axis=0), axis=1)))
    end = inv_T(T_w_c[0]) @ T_w_c[-1]
    print(f"{a.dataset}: klt-pnp, depth filter {a.mode} (image sigma {a.image_sigma_px} px), frames {n}, path "
          f"{path:.1f} m: end drift {100 * np.linalg.norm(cur['T'][:3, 3] - end[:3, 3]) / path:.2f} %, "
          f"{cur['n']} updates, {filt.demoted} demoted, filter {1e3 * cur['cpu'] / n:.2f} CPU ms per frame")


if __name__ == "__main__":
    main()
