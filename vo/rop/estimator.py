"""``RopEstimator`` ("rop"): seed 000's stereo VO - four ROPs per epoch pair, ROP adjustment, chaining.

Epochs (our extension, seed 000 uses strictly consecutive epochs): images 1, 2 are the last
*keyframe* epoch, images 3, 4 the current frame; every frame is solved against the keyframe
(``T_o_c0 = T_o_kf @ T_kf_c3``) and the current frame becomes the keyframe once the adjusted
translation reaches ``keyframe_baseline_ratio`` x the stereo baseline (or the four-view tracks
thin out below ``keyframe_min_track_ratio`` of the keyframe's; seed 003's empty-cell fraction is not
used: border cells never get corners, so it sits near its 0.42 threshold from the start). Only keyframe-to-keyframe steps chain, and
the essential-matrix directions of ROPs 1-3 / 2-4 are solved with a parallax comparable to the
baseline instead of one frame's (a few pixels), where they are ill-conditioned.

Per frame: four-view KLT tracks (:mod:`vo.rop.tracks`; ``frontend="orb"|"sift"`` matches the four
pairs with :mod:`vo.frontend` instead), a rotation-only fit and parallax
(:mod:`vo.rop.rotation_only`); if the median parallax is below ``min_parallax_px`` the epoch is
"no translation": ``T_kf_c3 = (R_1_3, 0)``, status ``ok`` with a message (our extension: the
essential matrices are undefined without translation). Otherwise the four ROPs (RANSAC essential
matrix + Sampson LM, :mod:`vo.rop.relative`, disambiguated against the ROPs predicted from the
rotation-only fit and constant velocity - planar scenes); a ROP whose implied ``R_1_3`` is more than
``max_rop_rotation_deg`` (1 deg) off the consensus of the others (the other planar solution, 3-50 deg away, or
the same-camera pair 13 + 24 bent by a single-depth wall, see :meth:`RopEstimator._rotation_consensus`), or with fewer than ``max(min_rop_inliers,
min_inlier_ratio * matches)`` inliers is rejected (extension); with >= 3 ROPs: initial EOPs and the
two-step adjustment (eqs. 1-3, :mod:`vo.rop.adjustment`, unchanged).

Covariance of ``[rotvec, position]`` of ``T_o_c0`` (left perturbation), first order:
``cov = A cov_kf A^T + B cov_step B^T`` (see :func:`propagate_cov`); keyframe steps are treated as
independent (consecutive steps share an epoch; approximate; ``cov="chain_bootstrap"`` keeps their
correlation). ``cov="propagated"`` (default, our
extension): each ROP's own Sampson covariance (residual RMS, inlier count and geometry) propagated
through the adjustment's converged gains (:mod:`vo.rop.propagation`); ``cov="joint"`` (our
extension, KLT front-end only; other front-ends fall back to ``"propagated"``) the same with the
joint covariance of the four ROPs from the pixel noise of their shared tracks (:mod:`vo.rop.joint_cov`);
``cov="bootstrap"`` (our extension) a nonparametric bootstrap over the epoch's tracks, RANSAC, ROPs
and adjustment repeated per replicate (``bootstrap_replicates``, default 40; :mod:`vo.rop.bootstrap_cov`)
at keyframe steps, the first-order step covariance scaled per axis by the last bootstrap's ratio in
between (about +1 s per keyframe at 40 replicates): it sees the feature / inlier-selection spread
that the first-order models miss (docs/consistency.md); ``cov="chain_bootstrap"`` (our extension,
:mod:`vo.rop.chain_bootstrap`) the same per-step replicates, but each track keeps its Poisson
multiplicity for its whole life and each replicate composes its own trajectory, so the keyframe
covariance is that of the replicate trajectories and keeps the correlation of consecutive steps
through shared tracks (descriptor front-ends: independent draws per step); ``cov="noise_chain"`` (our
extension, KLT only, :mod:`vo.rop.noise_chain`) the same replicate trajectories, but each replicate
perturbs the tracks by image-noise footprints (``image_noise_sigma``, None: estimated from the
images) instead of resampling them: the prediction for runs that differ only in image noise; ``cov="apost"`` the
adjustment's a-posteriori unit-weight variances; ``cov="apriori"`` its a-priori sigmas, *derived
per epoch* from the ROPs' Sampson sigmas ``s_p`` as ``s_0^2 = mean_p(w_p s_p^2)`` unless
``sigma_rot_deg`` / ``sigma_dir_deg`` fix them. docs/consistency.md has the Monte-Carlo check.
Rotation-only epochs: rotation sigma ``3 max(parallax, 0.1 px) / (f sqrt(n))`` per axis; position
sigma ``baseline x max(parallax, min_parallax/2) / median disparity`` per axis (the translation
that would produce that parallax at the median stereo depth).

Weights: ``weights="inliers"`` (default) is seed 000's inlier-count weighting; ``"sampson"`` (our
extension) weights each ROP by the inverse of its Sampson variance, which down-weights the
ill-conditioned same-camera ROPs 1-3 / 2-4 on forward motion towards a wall (indoor heading drift).

On failure the pose is extrapolated at constant velocity (``constant_velocity``, default; False
holds it) with the rotation of the rotation-only fit to the left tracks when there are
>= :data:`MIN_ROTATION_TRACKS` (a failed frame in a fast turn keeps its heading), never NaN, and the
current frame becomes a fresh keyframe (re-initialisation). Every solved frame appends an
:class:`~vo.rop.epochs.EpochRecord` (initial and adjusted ``T_kf_c``) to ``self.epochs``. Timings (ms): detect, track, stereo,
essential, initial, adjust, total.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from vo.dataset.types import StereoFrame
from vo.errors import EstimatorError
from vo.estimators.base import Estimator, FrameResult
from vo.frontend.klt import KltConfig
from vo.frontend.lk_noise import lk_noise_cov
from vo.frontend.noise_level import estimate_noise_sigma
from rigs.geometry import inv_T, make_T, rotation_angle, skew
from vo.rop import matching
from vo.rop.adjustment import AdjustmentConfig, adjust_rops
from vo.rop.bootstrap_cov import MIN_REPLICATES, bootstrap_step_replicates, replicate_cov
from vo.rop.chain_bootstrap import ReplicateChain
from vo.rop.noise_chain import NoiseChain, noise_step_replicates
from vo.rop.epochs import EpochRecord
from vo.rop.initial import initial_eops, rotation_candidates
from vo.rop.joint_cov import with_pixel_factors
from vo.rop.relative import LOSSES, METHODS, estimate_rop_normalized
from vo.rop.ropset import PAIRS, WEIGHTINGS, RopSet, exact_ropset
from vo.rop.rotation_only import rotation_only
from vo.rop.tracks import KltFourView

COVS = ("propagated", "apost", "apriori", "joint", "bootstrap", "chain_bootstrap", "noise_chain")
BOOTSTRAPS = ("bootstrap", "chain_bootstrap", "noise_chain")
DEFAULTS = dict(frontend="klt", ransac_threshold_px=1.0, ransac_method="ransac", ransac_max_iters=200,
                ransac_prob=0.999, min_matches=30, min_rop_inliers=20, min_inlier_ratio=0.5, seed=0,
                cov="propagated", weights="inliers", sigma_rot_deg=None, sigma_dir_deg=None, constant_velocity=True,
                min_parallax_px=0.75, max_rop_rotation_deg=1.0, keyframe_baseline_ratio=2.0, keyframe_min_track_ratio=0.5,
                klt_config=None, klt_refine="translation", bootstrap_replicates=40, image_noise_sigma=None,
                rop_loss="gate")
MIN_ROTATION_TRACKS = 8     # left tracks for the rotation-only fit of a failed frame
MAX_COAST_FRAMES = 10        # constant-velocity extrapolation limit (then the translation is held)
TWIN_DEG = 1.0               # 2-2 ties closer than this keep all four ROPs (never, at the default 1 deg gate)
STAGES = ("detect", "track", "stereo", "essential", "initial", "adjust")


def propagate_cov(cov_old: np.ndarray, T_o_c1: np.ndarray, T_c1_c3: np.ndarray, cov_step: np.ndarray) -> np.ndarray:
    """(6,6) covariance of ``T_o_c3 = T_o_c1 @ T_c1_c3`` (first order): ``A cov_old A^T + B cov_step B^T``,
    ``A = [[I, 0], [-skew(R p), I]]``, ``B = blockdiag(R, R)``, ``R = R_o_c1``, ``p = t_c1_c3``."""
    R = T_o_c1[:3, :3]
    A = np.eye(6)
    A[3:, :3] = -skew(R @ T_c1_c3[:3, 3])
    B = np.zeros((6, 6))
    B[:3, :3] = B[3:, 3:] = R
    C = A @ cov_old @ A.T + B @ cov_step @ B.T
    return 0.5 * (C + C.T)


def _check_noise_options(o: dict) -> None:
    """``cov="noise_chain"`` needs the KLT front-end (its footprints are LK's); ``image_noise_sigma``
    None (estimated from the images) or a finite number >= 0 (grey levels)."""
    if o["cov"] == "noise_chain" and o["frontend"] != "klt":
        raise EstimatorError(f"rop.cov: 'noise_chain' needs frontend='klt' (LK footprints), got frontend={o['frontend']!r}")
    s = o["image_noise_sigma"]
    if s is not None and (isinstance(s, bool) or not isinstance(s, (int, float)) or not np.isfinite(s) or s < 0):
        raise EstimatorError(f"rop.image_noise_sigma: {s!r}; must be None (estimated) or a finite number >= 0 (grey levels)")


def apriori_sigmas(ropset: RopSet) -> tuple:
    """Unit-weight ``(sigma_rot_rad, sigma_dir_rad)`` from the ROPs' Sampson sigmas (module docstring)."""
    ok = [p for p in ropset.ok_pairs if ropset.rops[p].sigma_rot_rad is not None]
    if not ok:
        return None, None
    w_rot, w_dir = ropset.weights("rot"), ropset.weights("dir")
    s_rot = np.sqrt(np.mean([w_rot[p] * ropset.rops[p].sigma_rot_rad ** 2 for p in ok]))
    s_dir = np.sqrt(np.mean([w_dir[p] * ropset.rops[p].sigma_dir_rad ** 2 for p in ok]))
    return max(float(s_rot), 1e-9), max(float(s_dir), 1e-9)


class RopEstimator(Estimator):
    """Options (defaults in :data:`DEFAULTS`): ``frontend`` "klt"|"orb"|"sift"; RANSAC
    ``ransac_threshold_px``, ``ransac_method`` "ransac"|"magsac", ``ransac_max_iters``, ``ransac_prob``,
    ``seed``; ``min_matches`` (four-view tracks / pair matches), ``min_rop_inliers``,
    ``min_inlier_ratio``, ``max_rop_rotation_deg``; ``weights`` "inliers"|"sampson";
    ``cov`` "propagated"|"joint"|"bootstrap"|"chain_bootstrap"|"noise_chain"|"apost"|"apriori", ``bootstrap_replicates``,
    ``image_noise_sigma`` (grey levels, ``noise_chain``; None: estimated per frame),
    ``sigma_rot_deg`` / ``sigma_dir_deg`` (None: derived);
    ``constant_velocity``; ``min_parallax_px``; ``keyframe_baseline_ratio``; ``keyframe_min_track_ratio``;
    ``klt_config`` (:class:`KltConfig` or a mapping of its fields, ``--opt 'klt_config={win: 11}'``); ``klt_refine`` "translation" (seed 003's LK) | "affine" (tracks refined
    by an affine window warp against the keyframe, :mod:`vo.rop.tracks`); ``rop_loss`` "gate" (default:
    RANSAC inliers re-selected at a hard 1 px Sampson gate, least squares) | "tukey" | "cauchy"
    (robust final fit with no step: :func:`vo.rop.relative.estimate_rop_normalized`; the gate has
    two self-consistent inlier sets on some ROPs and noise flips between them, docs/consistency.md)."""

    name = "rop"

    def __init__(self, rig, **options):
        super().__init__(rig, **options)
        bad = sorted(set(options) - set(DEFAULTS))
        if bad:
            raise EstimatorError(f"rop: unknown option(s) {bad}; valid: {', '.join(sorted(DEFAULTS))}")
        if not rig.is_stereo:
            raise EstimatorError(f"rop: rig {rig.name!r} has one camera; seed 000 needs a stereo rig")
        o = {**DEFAULTS, **options}
        for key, valid in (("frontend", matching.KINDS), ("cov", COVS), ("ransac_method", tuple(METHODS)),
                           ("weights", WEIGHTINGS), ("klt_refine", KltFourView.REFINES), ("rop_loss", LOSSES)):
            if o[key] not in valid:
                raise EstimatorError(f"rop.{key}: {o[key]!r}; valid: {', '.join(valid)}")
        reps = o["bootstrap_replicates"]
        if isinstance(reps, bool) or not isinstance(reps, (int, np.integer)) or reps < MIN_REPLICATES:
            raise EstimatorError(f"rop.bootstrap_replicates: {reps!r}; must be an integer >= {MIN_REPLICATES}")
        _check_noise_options(o)
        self.o = o
        self.cams = rig.cameras[:2]
        self.focal = float(np.mean([c.fx for c in self.cams] + [c.fy for c in self.cams]))
        self.T_c1_c2 = rig.T_c0_c1
        self.baseline = float(np.linalg.norm(self.T_c1_c2[:3, 3]))
        self.config = AdjustmentConfig(
            sigma_rot_rad=None if o["sigma_rot_deg"] is None else np.radians(float(o["sigma_rot_deg"])),
            sigma_dir_rad=None if o["sigma_dir_deg"] is None else np.radians(float(o["sigma_dir_deg"])))
        self.klt = KltFourView(rig, KltConfig.from_option(o["klt_config"], "rop.klt_config"),
                                o["klt_refine"]) if o["frontend"] == "klt" else None
        self.T_o_c0, self.cov = np.eye(4), np.zeros((6, 6))
        self.T_o_kf, self.cov_kf = np.eye(4), np.zeros((6, 6))
        self._kf_imgs = None          # (left, right) of the keyframe; None before the first frame
        self._n_kf = 0
        self._T_kf_cur = np.eye(4)
        self._last_motion = np.eye(4)
        self._lost = False
        self._R_rot_only = None
        self._n_coast = 0
        self._t_kf = None
        self._boot_scale = None       # cov="bootstrap": per-axis std ratio bootstrap / first order, last keyframe
        self._boot_len = None         # step length (m) at the last bootstrap
        self._chained = False         # a keyframe step has been chained (start-up is over)
        chain = {"chain_bootstrap": ReplicateChain, "noise_chain": NoiseChain}.get(o["cov"])
        self._chain = chain(reps, np.random.default_rng([int(o["seed"]), 0xC4A1])) if chain else None
        self._cur_imgs = None         # (left, right) of the frame being solved (cov="noise_chain")
        self._ids = None              # this frame's track identities (KLT front-end)
        self._epoch = None            # (kind, T_initial, T_minimal, ropset) of the frame being solved
        self.epochs: list[EpochRecord] = []   # one per frame solved against its keyframe (Fig. 5 check)

    # ------------------------------------------------------------------------------ front-end
    def _new_keyframe(self, left, right, timings, keep_tracks: bool) -> int:
        self.T_o_kf, self.cov_kf, self._T_kf_cur = self.T_o_c0.copy(), self.cov.copy(), np.eye(4)
        self._kf_imgs = (left, right)
        self._t_kf = self._t_cur
        if self.klt is not None:
            self._n_kf = self.klt.keyframe(left, right, timings, keep_tracks)
        else:
            self._n_kf = 1
        return self._n_kf

    def _pairs(self, left, right, timings) -> tuple[dict, int, float]:
        """{pair: (x_i, x_j)}, number of usable features, median stereo disparity (px) at the keyframe."""
        if self.klt is not None:
            v = self.klt.track(left, right, timings)
            self._ok4, self._ids = v.ok4, v.ids
            disp = np.median(np.linalg.norm(v.x1 - v.x2, axis=1)) * self.focal if len(v) else 0.0
            return {p: v.pair(p) for p in PAIRS}, int(v.ok4.sum()), float(disp)
        t0 = time.perf_counter()
        kl, kr = self._kf_imgs
        pairs = matching.descriptor_pairs({1: kl, 2: kr, 3: left, 4: right}, self.cams, self.o["frontend"])
        timings["track"] += (time.perf_counter() - t0) * 1e3
        return pairs, min(len(a) for a, _ in pairs.values()), 0.3 * self.focal

    # ------------------------------------------------------------------------------- solving
    def _priors(self, R_1_3: np.ndarray) -> dict:
        """Predicted ROPs: rotation from the rotation-only fit, translation from constant velocity."""
        t_pred = (self._T_kf_cur @ self._last_motion)[:3, 3]
        if np.linalg.norm(t_pred) < 1e-6:
            t_pred = np.array([0.0, 0.0, 1e-3])          # at rest: forward (cross pairs barely care)
        ex = exact_ropset(make_T(R_1_3, t_pred), self.T_c1_c2)
        return {p: (m.R_i_j, m.rhat_i_j) for p, m in ex.rops.items()}

    def _rops(self, pairs: dict, R_1_3: np.ndarray) -> RopSet:
        o, rops = self.o, {}
        priors = self._priors(R_1_3)
        for p, (x_i, x_j) in pairs.items():
            if len(x_i) < o["min_matches"]:
                continue
            m = estimate_rop_normalized(x_i, x_j, self.focal, o["seed"], o["ransac_threshold_px"], o["ransac_prob"],
                                        max_iters=o["ransac_max_iters"], method=o["ransac_method"], prior=priors[p],
                                        loss=o["rop_loss"])
            need = max(o["min_rop_inliers"], o["min_inlier_ratio"] * len(x_i))
            if m.ok and m.n_inliers < need:
                m = dataclasses.replace(m, ok=False, message=f"{m.n_inliers} inliers < {need:.0f}")
            rops[p] = m
        return self._rotation_consensus(RopSet(rops, self.T_c1_c2, o["weights"]), R_1_3)

    def _rotation_consensus(self, ropset: RopSet, R_1_3: np.ndarray) -> RopSet:
        """Reject ROPs whose implied ``R_1_3`` is > ``max_rop_rotation_deg`` from the consensus: the
        implied rotation agreeing with most others (our extension). A tie (2 vs 2) between groups
        less than :data:`TWIN_DEG` apart keeps all four and the adjustment averages them; ties further
        apart go to the group closest to the rotation-only fit.

        Default gate 1 deg and :data:`TWIN_DEG` 1 deg (were 2 and 3): on forward motion towards a
        texture-poor wall, ROPs 13 and 24 share their tracks and bend together by 0.5-3 deg while the
        cross ROPs 14 / 23 stay within ~0.2 deg; inlier counts are equal, so the paper's weights
        averaged the two groups (half the error kept). With the tighter gate such a 2-2 split is a
        tie resolved by the rotation-only fit, which drops the bent pair. Indoor drift over seeds
        0-3: 1.07 / 1.11 / 0.89 / 2.38 % -> 0.94 / 0.98 / 0.45 / 0.62 %; campus unchanged. Tuned:
        gate = twin = 1.5 deg gave mean 1.15 %, 0.5 deg lost an epoch run on seed 2 (8.3 %)."""
        ok = ropset.ok_pairs
        if len(ok) < 2:
            return ropset
        cands = dict(zip(ok, rotation_candidates(ropset, ok)[0]))
        gate = np.radians(self.o["max_rop_rotation_deg"])
        dev = {(a, b): rotation_angle(cands[a].T @ cands[b]) for a in ok for b in ok}
        support = {a: sum(dev[a, b] <= gate for b in ok) for a in ok}
        best = max(support.values())
        tied = [a for a in ok if support[a] == best]
        if 2 * best == len(ok) and max(dev[a, b] for a in tied for b in tied) < np.radians(TWIN_DEG):
            return ropset
        ref = min(tied, key=lambda a: rotation_angle(cands[a].T @ R_1_3))
        rops = dict(ropset.rops)
        for p in ok:
            if dev[ref, p] > gate:
                rops[p] = dataclasses.replace(rops[p], ok=False,
                                              message=f"rotation {np.degrees(dev[ref, p]):.1f} deg off the consensus")
        return RopSet(rops, self.T_c1_c2, ropset.weighting)

    def _adjust(self, ropset: RopSet, timings):
        """-> (T_c1_c3, cov_step, message); T None on failure."""
        if len(ropset.ok_pairs) < 3:
            msgs = "; ".join(f"{p}: {m.message}" for p, m in ropset.rops.items() if not m.ok)
            return None, None, f"{len(ropset.ok_pairs)} of 4 ROPs usable ({msgs or 'too few matches'})"
        t1 = time.perf_counter()
        init = initial_eops(ropset)
        minimal = initial_eops(ropset, mode="minimal")          # the paper's simplest reading (Fig. 5 check)
        self._epoch = ("rops", init.T_c1_c3, None if minimal.degenerate else minimal.T_c1_c3, ropset)
        t2 = time.perf_counter()
        cfg = self.config
        if self.o["cov"] == "apriori" and cfg.sigma_rot_rad is None:
            s_rot, s_dir = apriori_sigmas(ropset)
            cfg = dataclasses.replace(cfg, sigma_rot_rad=s_rot, sigma_dir_rad=s_dir)
        res = adjust_rops(ropset, init, cfg)
        timings["initial"] += (t2 - t1) * 1e3
        timings["adjust"] += (time.perf_counter() - t2) * 1e3
        cov = {"apriori": res.cov_apriori, "apost": res.cov_apost}.get(self.o["cov"], res.cov_propagated)
        if cov is None and self.o["cov"] in ("propagated", "joint"):
            cov = res.cov_apost
        if res.degenerate or cov is None or not np.all(np.isfinite(res.T_c1_c3)) or not np.all(np.isfinite(cov)):
            return None, None, f"degenerate ROP geometry: {res.message or 'no redundancy'}"
        return res.T_c1_c3, cov, ""

    def _bootstrap_cov(self, pairs: dict, T_kf_c3: np.ndarray, cov_step: np.ndarray, fresh: bool, timings) -> tuple:
        """``cov="bootstrap"`` / ``"chain_bootstrap"``: the step covariance of the bootstrap replicates
        (:func:`vo.rop.bootstrap_cov.bootstrap_step_replicates`; with the chain, at keyframe steps the
        tracks' persistent multiplicities) -> ``(cov_step, replicates or None)``
        (RANSAC repeated per replicate; seeded by ``(seed, t_ns)``, so a rerun gives the same bytes) at
        keyframe steps (``fresh``; the ones that chain), at the first ROP epoch and, until the first
        keyframe step is chained, whenever the step has doubled in length (:meth:`_startup_due`); other frames scale
        the first-order ``cov_step`` per axis by the last bootstrap's std ratio (``D C D``).
        Rotation-only epochs keep their covariance."""
        if self._epoch is None or self._epoch[0] != "rops":
            return cov_step, None
        if fresh or self._boot_scale is None or self._startup_due(T_kf_c3):
            t0 = time.perf_counter()
            reps = self._replicates(pairs, fresh)
            C = replicate_cov(reps, T_kf_c3)
            timings["adjust"] += (time.perf_counter() - t0) * 1e3
            if C is None:
                return cov_step, None
            d = np.sqrt(np.maximum(np.diag(cov_step), 1e-300))
            self._boot_scale = np.sqrt(np.diag(C)) / d
            self._boot_len = float(np.linalg.norm(T_kf_c3[:3, 3]))
            return C, reps
        D = np.diag(self._boot_scale)
        return D @ cov_step @ D, None

    def _replicates(self, pairs: dict, fresh: bool) -> list:
        """The step's bootstrap replicates (:meth:`_bootstrap_cov`): tracks resampled (with the chain,
        by their kept multiplicities at keyframe steps) or, ``cov="noise_chain"``, perturbed by image
        noise footprints (:mod:`vo.rop.noise_chain`; kept across the keyframe when ``fresh``)."""
        o = self.o
        kw = dict(config=self.config, rng=np.random.default_rng([int(o["seed"]), int(self._t_cur)]),
                  threshold=o["ransac_threshold_px"] / self.focal, min_inliers=o["min_rop_inliers"],
                  ransac=dict(max_iters=o["ransac_max_iters"], prob=o["ransac_prob"], method=o["ransac_method"],
                              loss=o["rop_loss"]))
        if o["cov"] == "noise_chain":
            view = self.klt.view
            offsets = self._chain.offsets(view.ids, self._footprint_covs(view))
            if fresh:
                self._chain.commit()
            return noise_step_replicates(self._epoch[3], view, offsets, self.klt.normalize, **kw)
        counts = self._chain.counts(self._ids) if self._chain is not None and self.klt is not None and fresh else None
        return bootstrap_step_replicates(self._epoch[3], pairs, self._ok4 if self.klt is not None else None, counts,
                                         n_boot=int(o["bootstrap_replicates"]), **kw)

    def _footprint_covs(self, view) -> np.ndarray:
        """(N,4,2,2) image-noise footprint covariances of the tracks in views 1-4 (keyframe left/right,
        current left/right; :func:`vo.frontend.lk_noise.lk_noise_cov`); sigma the option or estimated
        from the current left image (:func:`vo.frontend.noise_level.estimate_noise_sigma`)."""
        sigma = self.o["image_noise_sigma"]
        if sigma is None:
            sigma = estimate_noise_sigma(self._cur_imgs[0])
        p4 = np.where(view.ok4[:, None], view.p4, view.p3)
        imgs = (*self._kf_imgs, *self._cur_imgs)
        win = self.klt.config.win
        return np.stack([lk_noise_cov(img, p, win, sigma) for img, p in zip(imgs, (view.p1, view.p2, view.p3, p4))], 1)

    def _startup_due(self, T_kf_c3: np.ndarray) -> bool:
        """Before the first keyframe step is chained the step covariance is the whole covariance, and
        the bootstrap / first-order ratio changes as the parallax grows from < 1 px: bootstrap again
        each time the step has doubled in length since the last bootstrap (about 3 extra per run)."""
        return not self._chained and self._boot_len is not None and \
            float(np.linalg.norm(T_kf_c3[:3, 3])) >= 2.0 * max(self._boot_len, 1e-6)

    def _rotation_only_step(self, R_1_3, parallax, n, disparity):
        cov = np.zeros((6, 6))
        s_rot = 3.0 * max(parallax, 0.1) / (self.focal * np.sqrt(max(n, 1)))
        s_pos = self.baseline * max(parallax, 0.5 * self.o["min_parallax_px"]) / max(disparity, 1.0)
        cov[:3, :3], cov[3:, 3:] = s_rot ** 2 * np.eye(3), s_pos ** 2 * np.eye(3)
        return make_T(R_1_3, np.zeros(3)), cov

    def _step(self, pairs, n_feat, disparity, timings):
        """-> (T_kf_c3, cov_step, status, message); T None on failure."""
        t0 = time.perf_counter()
        x1, x3 = pairs["13"]
        R_1_3, parallax, _ = rotation_only(x1, x3, self.focal)
        self._R_rot_only = R_1_3 if len(x1) >= MIN_ROTATION_TRACKS else None
        min_par = self.o["min_parallax_px"]
        if parallax < min_par:
            timings["essential"] += (time.perf_counter() - t0) * 1e3
            T, cov = self._rotation_only_step(R_1_3, parallax, len(x1), disparity)
            self._epoch = ("rotation_only", T, T, None)
            return T, cov, "ok", f"parallax {parallax:.2f} px < {min_par} px: no translation (rotation only)"
        ropset = self._rops(pairs, R_1_3)
        if self.o["cov"] == "joint" and self.klt is not None:
            ropset = with_pixel_factors(ropset, pairs, self._ok4)
        timings["essential"] += (time.perf_counter() - t0) * 1e3
        T, cov, msg = self._adjust(ropset, timings)
        if T is None and parallax < 2.0 * min_par:
            T, cov = self._rotation_only_step(R_1_3, parallax, len(x1), disparity)
            self._epoch = ("rotation_only", T, T, None)
            return T, cov, "ok", f"parallax {parallax:.2f} px, {msg}: rotation only"
        return T, cov, ("lost" if T is None else "ok"), msg

    def _left_rotation(self, pairs: dict):
        """``R_1_3`` of the rotation-only fit to the left-image tracks (pair 13 needs no stereo match),
        or None below :data:`MIN_ROTATION_TRACKS`: a failed frame in a fast turn keeps its heading."""
        x1, x3 = pairs["13"]
        return rotation_only(x1, x3, self.focal)[0] if len(x1) >= MIN_ROTATION_TRACKS else None

    def _is_keyframe(self, T_kf_c3, n_feat) -> bool:
        o = self.o
        if np.linalg.norm(T_kf_c3[:3, 3]) >= o["keyframe_baseline_ratio"] * self.baseline:
            return True
        if n_feat < max(2 * o["min_matches"], o["keyframe_min_track_ratio"] * self._n_kf):
            return True
        return False

    def _record_epoch(self, t_ns: int, T_kf_c3: np.ndarray) -> None:
        if self._epoch is None:
            return
        kind, T_init, T_min, ropset = self._epoch
        n = {p: ropset.rops[p].n_inliers for p in ropset.ok_pairs} if ropset is not None else {}
        rops = {p: (ropset.rops[p].R_i_j, ropset.rops[p].rhat_i_j) for p in ropset.ok_pairs} if ropset else {}
        self.epochs.append(EpochRecord(self._t_kf, t_ns, kind, T_init, T_kf_c3.copy(), T_min, n, rops))

    # ------------------------------------------------------------------------------- frames
    def _result(self, frame, status, n_feat, n_inl, msg, timings, t0) -> FrameResult:
        timings["total"] = (time.perf_counter() - t0) * 1e3
        return FrameResult(frame.t_ns, self.T_o_c0.copy(), status, int(n_feat), int(n_inl), self.cov.copy(), msg, timings)

    def _fail(self, frame, left, right, status, n_feat, msg, timings, t0, R_1_3=None) -> FrameResult:
        """Coast: the rotation-only fit's rotation when there was one (tracks survive a failed ROP
        solve), the translation held or, with ``constant_velocity``, extrapolated; then a fresh keyframe."""
        T_prev = self.T_o_c0
        coast = self.o["constant_velocity"] and self._n_coast < MAX_COAST_FRAMES
        T_step = self._T_kf_cur @ self._last_motion if coast else self._T_kf_cur.copy()
        if R_1_3 is not None:
            T_step = make_T(R_1_3, T_step[:3, 3])
        T_new = self.T_o_kf @ T_step
        if np.all(np.isfinite(T_new)):
            self.T_o_c0 = T_new
        self._last_motion = inv_T(T_prev) @ self.T_o_c0
        self._n_coast += 1
        if self._chain is not None:
            self._chain.reset(self.T_o_c0, self.cov)
        self._new_keyframe(left, right, timings, keep_tracks=False)
        self._lost = True
        msg += ("; rotation from the rotation-only fit" if R_1_3 is not None else "") + "; translation " + \
               ("extrapolated (constant velocity)" if coast else "held") + \
               ", re-initialising from this frame"
        return self._result(frame, status, n_feat, 0, msg, timings, t0)

    def process(self, frame: StereoFrame) -> FrameResult:
        t0 = time.perf_counter()
        timings = dict.fromkeys(STAGES, 0.0)
        left, right = _gray(frame.left), _gray(frame.right)
        self._R_rot_only, self._epoch, self._t_cur = None, None, int(frame.t_ns)
        self._cur_imgs = (left, right)
        if self._kf_imgs is None:
            n = self._new_keyframe(left, right, timings, keep_tracks=False)
            return self._result(frame, "init", n, 0, "first frame defines O", timings, t0)
        pairs, n_feat, disparity = self._pairs(left, right, timings)
        if n_feat < self.o["min_matches"]:
            return self._fail(frame, left, right, "few_features", n_feat,
                              f"{n_feat} four-view features < {self.o['min_matches']}: texture-poor view?", timings, t0,
                              self._left_rotation(pairs))
        T_kf_c3, cov_step, status, msg = self._step(pairs, n_feat, disparity, timings)
        if T_kf_c3 is None:
            return self._fail(frame, left, right, status, n_feat, msg, timings, t0, self._R_rot_only)
        self._record_epoch(frame.t_ns, T_kf_c3)
        is_kf = self._is_keyframe(T_kf_c3, n_feat)
        reps = None
        if self.o["cov"] in BOOTSTRAPS:
            cov_step, reps = self._bootstrap_cov(pairs, T_kf_c3, cov_step, fresh=is_kf, timings=timings)
        T_prev = self.T_o_c0
        self.T_o_c0 = self.T_o_kf @ T_kf_c3
        self.cov = propagate_cov(self.cov_kf, self.T_o_kf, T_kf_c3, cov_step)
        self._chained |= is_kf
        if is_kf and self._chain is not None:
            self.cov = self._chain.step(T_kf_c3, reps, cov_step, self.T_o_c0)
        self._last_motion, self._T_kf_cur, self._n_coast = inv_T(T_prev) @ self.T_o_c0, T_kf_c3, 0
        if self._lost:
            status, msg, self._lost = "reinit", ("re-initialised after a failed frame; " + msg).rstrip("; "), False
        if is_kf:
            self._new_keyframe(left, right, timings, keep_tracks=True)
            status = "keyframe" if status == "ok" else status
        return self._result(frame, status, n_feat, n_feat, msg, timings, t0)


def _gray(img: np.ndarray) -> np.ndarray:
    """(H,W) or (H,W,3) RGB uint8 -> (H,W) uint8 grayscale."""
    if img.ndim == 2:
        return img
    import cv2
    return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
