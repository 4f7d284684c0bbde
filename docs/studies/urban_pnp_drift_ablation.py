"""Where ``klt-pnp``'s rotation drift on ``urban-dynamic`` comes from: replace one input at a time by the truth.

Runs ``klt-pnp`` with the truth's inputs given through its constructor (``tracker``, ``landmark_source``;
oracle segmentation: the PnP sees only features the true segmentation calls static, so
moving objects are out) on a dataset written with ``--segmentation --depth`` and, per ablation, replaces:

* ``depth``: ``stereo`` (the product: left/right KLT + triangulation), ``exact`` (the depth map at the left
  pixel, :func:`sim.app.validation.exact_points.local_depth`), ``exact+disp`` (exact depth seen through a
  disparity error drawn like the measured stereo-KLT one: ``z = f b / (f b / z_true + e)``, e ~ N(0, sigma_d));
* ``tracks``: ``klt`` (the product) or ``exact`` (each frame, the projection of the landmark's true surface
  point, from its birth pixel and exact depth, into the true camera; ``exact+px`` adds N(0, sigma_px) per axis);
* ``depth_ok``: ``valid`` keeps only landmarks whose exact depth is valid (no depth edge in the 5x5 window
  around the left pixel), also for the product's stereo depth: the same landmark set as the exact-depth
  ablations; ``finite`` drops only those with sky (no depth) in that window; ``all`` keeps every one; ``pixel``
  keeps the landmarks on depth edges too, with the exact depth of the pixel nearest the left point (one side of
  the edge: the best a stereo matcher could give them).

Prints, per ablation: the orientation error at the last frame as a rotation vector in the current camera
frame (roll = about the optical axis z, pitch = about x, yaw = about y; deg), the mean signed per-step
rotation error (mdeg, camera frame), the end drift (% of the path) and its vertical part (m), and the
measured stereo disparity error / temporal KLT error against the truth (median and 1.4826 MAD, px;
the MADs are the noise of the ``exact+disp`` / ``exact+px`` ablations). Usage::

    vo-testbed generate --scenario urban-dynamic --segmentation --depth --seed 0 --out DATA
    python docs/studies/urban_pnp_drift_ablation.py DATA [--max-frames 500] [--only NAME ...] [--opt KEY=VALUE]

(``--depth`` changes nothing else: the images equal those of the dataset written without it.) Results and
their reading: docs/estimators.md, "Cause of klt-pnp's remaining urban drift".
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from rigs.geometry import inv_T, transform_points
from sim.app.validation.exact_points import backproject, local_depth, project
from vo.dataset import open_dataset
from vo.estimators.pnp import KltPnpEstimator
from vo.frontend.klt import KltConfig, KltTracker, stereo_klt
from vo.frontend.stereo import triangulate
from vo.vins.truth_segmentation import FeatureLabels


@dataclass(frozen=True)
class Ablation:
    name: str
    depth: str = "stereo"          # stereo | exact | exact+disp
    tracks: str = "klt"            # klt | exact | exact+px
    depth_ok: str = "valid"        # all | valid | finite | pixel


ABLATIONS = (
    Ablation("product", depth_ok="all"),
    Ablation("product, depth-valid landmarks"),
    Ablation("product, no sky in the landmark's window", depth_ok="finite"),
    Ablation("(a) exact depth", depth="exact"),
    Ablation("(b) exact tracks", tracks="exact"),
    Ablation("(a)+(b) exact depth and tracks", depth="exact", tracks="exact"),
    Ablation("(c) exact + measured noise", depth="exact+disp", tracks="exact+px"),
    Ablation("(c') exact depth + measured px noise", depth="exact", tracks="exact+px"),
    Ablation("(c'') measured disparity noise + exact tracks", depth="exact+disp", tracks="exact"),
    Ablation("(d) exact depth, edge landmarks kept at their pixel's depth", depth="exact", depth_ok="pixel"),
)


def pixel_depth(depth: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(N,) exact depth (m) of the pixel nearest each point ``p`` (N,2) of the depth map (H,W); NaN where nothing
    is in range (sky) or nearer than 0.1 m. On a depth edge: the depth of one side."""
    ij = np.clip(np.round(p).astype(int), 0, [depth.shape[1] - 1, depth.shape[0] - 1])
    z = depth[ij[:, 1], ij[:, 0]].astype(float)
    return np.where(np.isfinite(z) & (z > 0.1), z, np.nan)


class TruthInputs:
    """The ablation's inputs from the truth, handed to ``klt-pnp`` through its constructor: :meth:`landmarks` is
    its ``landmark_source`` (the depth of new landmarks), :class:`ExactTracker` its ``tracker`` (exact tracks);
    ``k`` is the current frame's index (set before each frame), ``klt_config`` / ``pnp_config`` the estimator's."""

    def __init__(self, ds, abl: Ablation, noise: dict, seed: int):
        self.ds, self.rig, self.abl, self.noise, self.k = ds, ds.rig, abl, noise, 0
        self.klt_config = self.pnp_config = None
        self.rng = np.random.default_rng(seed)
        self.T_w_c = ds.groundtruth_cam0().T
        self.X_w: dict = {}        # track id -> true surface point (world)
        self.stats = {"disp": [], "track": []}

    def _depth(self, p_l):
        """-> (true p_c0, exact depth valid, which landmarks the ablation keeps)."""
        cam, depth = self.rig.cameras[0], self.ds.depth(self.k, 0)
        z, ok = local_depth(depth, p_l)
        if self.abl.depth_ok == "pixel":       # edge landmarks at the depth of their nearest pixel
            z_px = pixel_depth(depth, p_l)
            edge = ~ok & np.isfinite(z_px)
            z, ok = np.where(edge, z_px, z), ok | edge
        keep = {"valid": ok, "all": np.ones(len(ok), bool), "pixel": ok}.get(self.abl.depth_ok)
        if keep is None:        # "finite": only landmarks with sky (inf depth) in the 5x5 window are dropped
            ij = np.clip(np.round(p_l).astype(int), 2, [depth.shape[1] - 3, depth.shape[0] - 3])
            keep = np.all([np.isfinite(depth[ij[:, 1] + j, ij[:, 0] + i]) for i in range(-2, 3) for j in range(-2, 3)], 0)
        return backproject(cam, p_l, z), ok, keep

    def _stereo(self, left, right, p_l, pyramid=None):
        """-> (p_c0 used as landmark, p_c0 true, ok)."""
        c, cam = self.pnp_config, self.rig.cameras[0]
        p_r, ok = stereo_klt(left, right, p_l, self.rig, self.klt_config, pyramid)
        p_c_tri, ok_t = triangulate(self.rig, p_l, p_r, c.max_depth, c.max_triangulation_px)
        ok &= ok_t
        p_c_true, ok_z, keep = self._depth(p_l)
        ok &= ok_z if self.abl.depth != "stereo" or self.abl.tracks != "klt" else keep
        fb = cam.K[0, 0] * np.linalg.norm(self.rig.T_c0_c1[:3, 3])
        both = ok & ok_z
        self.stats["disp"].append(fb / p_c_tri[both, 2] - fb / p_c_true[both, 2])
        if self.abl.depth == "stereo":
            return p_c_tri, p_c_true, ok
        z = p_c_true[:, 2]
        if self.abl.depth == "exact+disp":
            d = fb / z + self.rng.normal(0.0, self.noise["disp"], len(z))
            ok &= d > fb / c.max_depth
            z = fb / np.where(d > 0, d, np.inf)
        return p_c_true * (z / p_c_true[:, 2])[:, None], p_c_true, ok

    def landmarks(self, left, right, ids, p_l):
        """``klt-pnp``'s landmark source: ``(p_c0 (N,3), ok (N,))`` of the new tracks ``ids`` at ``p_l``; records
        each kept track's true surface point."""
        p_c, p_c_true, ok = self._stereo(left, right, p_l)
        X_w = transform_points(self.T_w_c[self.k], p_c_true)
        for i, x in zip(ids[ok], X_w[ok]):
            self.X_w[int(i)] = x
        return p_c, ok

    def exact_tracks(self, tr) -> None:
        """Record the tracker ``tr``'s errors against the truth and, unless ``tracks`` is ``klt``, replace its
        points by the projections of their true surface points (``exact+px``: plus pixel noise)."""
        cam = self.rig.cameras[0]
        have = np.array([int(i) in self.X_w for i in tr.ids], bool)
        X = np.array([self.X_w[int(i)] for i in tr.ids[have]]).reshape(-1, 3)
        uv, front = project(cam, self.T_w_c[self.k], X)
        err = tr.pts[have] - uv
        self.stats["track"].append(err[front & np.all(np.abs(err) < 2.0, axis=1)])
        if self.abl.tracks == "klt":
            return
        if self.abl.tracks == "exact+px":
            uv = uv + self.rng.normal(0.0, self.noise["px"], uv.shape)
        inside = front & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] <= cam.width - 1) & (uv[:, 1] <= cam.height - 1)
        pts = tr.pts.copy()
        pts[np.flatnonzero(have)] = uv
        keep = have.copy()
        keep[np.flatnonzero(have)] = inside
        tr.pts = pts
        tr.keep(keep)


class ExactTracker(KltTracker):
    """The product's KLT tracker whose every :meth:`track` is followed by :meth:`TruthInputs.exact_tracks`."""

    def __init__(self, truth: TruthInputs, width: int, height: int, config: KltConfig):
        super().__init__(width, height, config)
        self.truth = truth

    def track(self, img, guess=None):
        ok = super().track(img, guess)
        self.truth.exact_tracks(self)
        return ok


def instrumented(ds, abl: Ablation, noise: dict, seed: int, labels=None, landmark_source=None, inputs=None, **options):
    """``(klt-pnp, TruthInputs)``: the estimator built with the ablation's truth inputs; with ``labels``
    (:class:`FeatureLabels`) its PnP sees only the truly static features (``pnp_select``); ``landmark_source``
    (default: :meth:`TruthInputs.landmarks`) wraps the truth's for a study that records more; ``inputs`` (default
    :class:`TruthInputs`) the class of the truth inputs, for a study that selects landmarks otherwise."""
    truth = (inputs or TruthInputs)(ds, abl, noise, seed)
    cam = ds.rig.cameras[0]
    tracker = ExactTracker(truth, cam.width, cam.height, KltConfig.from_option(options.get("klt_config")))
    select = (lambda px: ~labels.dynamic(truth.k, px)) if labels is not None else None
    est = KltPnpEstimator(ds.rig, pnp_select=select, tracker=tracker,
                          landmark_source=landmark_source or truth.landmarks, **options)
    truth.klt_config, truth.pnp_config = est.klt_config, est.pnp_config
    return est, truth


def rotvec_deg(R: np.ndarray) -> np.ndarray:
    return np.degrees(Rotation.from_matrix(R).as_rotvec())


def run(ds, abl: Ablation, max_frames: int, noise: dict, options: dict, seed: int = 0, inputs=None) -> dict:
    labels = FeatureLabels.of(ds)
    est, truth = instrumented(ds, abl, noise, seed, labels=labels, inputs=inputs, **options)
    T_w_c = truth.T_w_c
    n = min(max_frames, len(ds))
    T_est, steps = [], []
    for k, frame in enumerate(ds.frames(stop=n)):
        truth.k = frame.index
        T_est.append(est.process(frame).T_o_c0.copy())
        if k:
            T_true_step = inv_T(T_w_c[k - 1]) @ T_w_c[k]
            T_est_step = inv_T(T_est[-2]) @ T_est[-1]
            steps.append(rotvec_deg(T_true_step[:3, :3].T @ T_est_step[:3, :3]))
    T_true = inv_T(T_w_c[0]) @ T_w_c[n - 1]
    path = float(np.sum(np.linalg.norm(np.diff(T_w_c[:n, :3, 3], axis=0), axis=1)))
    e_o = T_est[-1][:3, 3] - T_true[:3, 3]
    e_w = T_w_c[0][:3, :3] @ e_o
    disp = np.concatenate(truth.stats["disp"]) if truth.stats["disp"] else np.zeros(0)
    track = np.concatenate(truth.stats["track"]) if truth.stats["track"] else np.zeros((0, 2))
    return {"rot": rotvec_deg(T_true[:3, :3].T @ T_est[-1][:3, :3]), "step": np.mean(steps, 0) * 1e3,
            "drift": 100 * np.linalg.norm(e_o) / path, "vert": float(e_w[2]), "n": n,
            "disp": robust(disp), "track": robust(track)}


def robust(e: np.ndarray) -> tuple:
    """(median, 1.4826 x median absolute deviation) per column: gross stereo / track mismatches aside."""
    if not len(e):
        return np.zeros(e.shape[1:]), np.zeros(e.shape[1:])
    med = np.median(e, axis=0)
    return med, 1.4826 * np.median(np.abs(e - med), axis=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--max-frames", type=int, default=500)
    ap.add_argument("--only", action="append", help="run only ablations whose name contains this")
    ap.add_argument("--disp-sigma", type=float, help="disparity noise px (default: measured on the product run)")
    ap.add_argument("--px-sigma", type=float, help="track noise px per axis (default: measured)")
    ap.add_argument("--opt", action="append", default=[], help="estimator option KEY=VALUE (YAML value)")
    a = ap.parse_args()
    options = {kv.split("=", 1)[0]: yaml.safe_load(kv.split("=", 1)[1]) for kv in a.opt}
    ds = open_dataset(a.dataset)
    noise = {"disp": a.disp_sigma or 0.0, "px": a.px_sigma or 0.0}
    chosen = [x for x in ABLATIONS if not a.only or any(s in x.name for s in a.only)]
    noisy = any("+" in x.depth or "+" in x.tracks for x in chosen)
    if noisy and chosen[0].name != "product" and not (a.disp_sigma and a.px_sigma):
        raise SystemExit("the noise ablations take their noise from the product run: include it (--only product) "
                         "or give --disp-sigma and --px-sigma")
    print(f"{a.dataset}, frames 0-{min(a.max_frames, len(ds)) - 1}, oracle segmentation; rotation errors in the "
          "camera frame (x pitch, y yaw, z roll), deg; step bias = mean signed step error, mdeg")
    print("| ablation | roll | pitch | yaw | step bias roll / pitch / yaw | drift % | vertical m | "
          "disparity err median / robust std px | track err median (u, v) / robust std px |")
    print("|---|---|---|---|---|---|---|---|---|")
    for abl in chosen:
        r = run(ds, abl, a.max_frames, noise, options)
        if abl.name == "product":
            noise["disp"] = a.disp_sigma or float(r["disp"][1])
            noise["px"] = a.px_sigma or float(np.mean(r["track"][1]))
        (tm, ts) = r["track"]
        print(f"| {abl.name} | {r['rot'][2]:+.2f} | {r['rot'][0]:+.2f} | {r['rot'][1]:+.2f} | "
              f"{r['step'][2]:+.2f} / {r['step'][0]:+.2f} / {r['step'][1]:+.2f} | {r['drift']:.2f} | {r['vert']:+.2f} | "
              f"{r['disp'][0]:+.3f} / {r['disp'][1]:.3f} | ({tm[0]:+.3f}, {tm[1]:+.3f}) / {np.mean(ts):.3f} |", flush=True)


if __name__ == "__main__":
    main()
