"""``RopEstimator`` ("rop"): seed 000's stereo VO - four ROPs per epoch pair, ROP adjustment, chaining.

Seed 000: images 1, 2 (left, right) of one epoch and 3, 4 of the next give four relative
orientations (ROPs 1-3, 1-4, 2-3, 2-4, essential matrices; :mod:`vo.rop.relative`); with the
calibrated stereo ROP they fix the initial EOPs of images 3, 4 (:mod:`vo.rop.initial_eops`) and the two-step
network adjustment (eqs. 1-3, :mod:`vo.rop.adjustment`) refines them; epochs are chained.

Our extensions (each documented in its module, figures in docs/estimators.md):

* Keyframe epochs: images 1, 2 are the last *keyframe*; every frame is solved against it
  (``T_o_c = T_o_kf @ T_kf_c``) and becomes the next keyframe once the adjusted translation reaches
  ``keyframe_baseline_ratio`` x the baseline or its tracks thin out below ``keyframe_min_track_ratio``
  of the keyframe's, so the essential-matrix directions are solved with a parallax comparable to the
  baseline instead of one frame's few pixels.
* Front-end: one set of four-view KLT tracks gives all four ROPs (:mod:`vo.rop.tracks`, seed 003's
  grid and LK; a track its temporal LK loses searched again from its predicted pixel, ``predict_tracks``,
  :mod:`vo.rop.track_start`); ``frontend="orb"|"sift"`` matches the four pairs instead (:mod:`vo.rop.matching`).
* Moving objects: the tracks of the rigid motion nearest the motion prior when several compete
  (``moving_objects``, :mod:`vo.rop.moving`). The prior is the constant-velocity prediction of the track
  filter's own PnP poses (``moving_prior="pnp"``), so that one wrong ROP step does not move the prediction
  onto a car. A ROP step more than ``moving_step_gate_m`` from the PnP pose of the same tracks fails the
  frame, which then takes that PnP pose. A ROP step whose rotation fails the test against that PnP pose's
  (``pnp_rotation_test``: "chi2", the difference in the metric of both fits' covariances with the run's
  variance factor, :mod:`vo.rop.rotation_test`; "degrees", more than ``pnp_rotation_gate_deg``,
  :func:`vo.rop.weak_frame.rotation_miss`) takes, with ``pnp_rotation_action="direction"``, the PnP rotation and
  translation direction and the length of seed 000's translation step re-solved for that rotation
  (:func:`vo.rop.rotation_test.readjusted_step`); ``"rotation"`` keeps the re-solved translation; ``"pose"`` takes
  the PnP pose and a new keyframe (a keyframe, not a lost frame). The pose of every other frame comes from the ROPs.
* Standstill: a rotation-only fit gives the parallax (:mod:`vo.rop.rotation_only`); below
  ``min_parallax_px`` the epoch is "no translation" (``T_kf_c = (R_1_3, 0)``, status ``ok``).
* ROP gates and the rotation consensus (:mod:`vo.rop.consensus`); >= 3 ROPs are needed.
* Failure: the pose is the track filter's PnP pose when it has >= :data:`MIN_COAST_PNP_INLIERS` inliers
  and lies within ``moving_prior_gate_m`` of the prediction (it uses the three-view tracks too); else a
  small PnP fit of the keyframe's stereo tracks when it is well conditioned (first-order rotation sigma,
  :mod:`vo.rop.weak_frame`: a rotation-only fit of 15 bunched tracks was 2 deg off); else it
  coasts at constant velocity (at most :data:`~vo.estimators.base.MAX_COAST_FRAMES` frames, then held)
  with the heading of the rotation-only fit to the left tracks when there are >=
  :data:`vo.rop.rotation_only.MIN_ROTATION_TRACKS`; never NaN; the frame becomes a fresh keyframe
  (keeping its tracks when only the ROP step was suspect).
* Covariance of ``T_o_c0`` from an :class:`~vo.rop.uncertainty.UncertaintyModel` (first order by
  default; ``cov="chain_bootstrap"``; or any model passed as ``uncertainty=``). Rotation-only epochs:
  rotation sigma ``3 max(parallax, 0.1 px) / (f sqrt(n))``, position sigma
  ``baseline x max(parallax, min_parallax / 2) / median disparity`` per axis.

Every solved frame appends an :class:`~vo.rop.epochs.EpochRecord` to ``self.epochs`` (Fig. 5 check). Timings (ms):
detect, track, stereo, essential, initial, adjust (covariance included), total.
"""
from __future__ import annotations

import time

import numpy as np

from rigs.geometry import inv_T, make_T
from rigs.records import StereoFrame
from vo.errors import EstimatorError
from vo.estimators.base import MAX_COAST_FRAMES, Estimator, FrameResult
from vo.estimators.pnp_core import PnpConfig
from vo.estimators.rigidity import RigidityConfig, rigid_subset
from rigs.image import to_gray
from vo.rop import matching
from vo.rop.adjustment import AdjustmentConfig, adjust_rops
from vo.rop.rop_config import RopConfig
from vo.rop.consensus import predicted_rops, rotation_consensus, solve_rops
from vo.rop.cov_models import make_uncertainty
from vo.rop.epochs import EpochRecord
from vo.rop.initial_eops import initial_eops
from vo.rop.moving import TrackFilter, filter_tracks
from vo.rop.offset import RopOffset
from vo.rop.ropset import PAIRS
from vo.rop.rotation_only import MIN_ROTATION_TRACKS, rotation_only, rotation_only_step
from vo.rop.rotation_test import RotationTester, readjusted_step
from vo.rop.track_start import predicted_left
from vo.rop.tracks import KltFourView
from vo.rop.uncertainty import Step, UncertaintyModel
from vo.rop.weak_frame import rotation_miss, weak_frame_pose
from vo.frontend.stereo import triangulate

MIN_COAST_PNP_INLIERS = 20  # PnP inliers of the track filter's motion for it to give a failed frame's pose
STAGES = ("detect", "track", "stereo", "essential", "initial", "adjust")


class RopEstimator(Estimator):
    """``RopEstimator(rig, config=None, uncertainty=None, tracker=None, **options)``: ``config`` a
    :class:`~vo.rop.rop_config.RopConfig`, or its fields as keyword options (``--opt``); ``uncertainty``
    an :class:`~vo.rop.uncertainty.UncertaintyModel` instead of the one ``config.cov`` names; ``tracker``
    the four-view tracker of the KLT front-end (``keyframe`` / ``track`` / ``normalize`` / ``view`` of
    :class:`~vo.rop.tracks.KltFourView`, the default built from ``klt_config`` and ``klt_refine``), e.g. a
    validation's exact tracks; ``step_observer(pairs, R_1_3, priors)`` is called with the inputs of each
    frame's ROP solve (studies: what a step was solved from); ``rigidity``
    (:class:`~vo.estimators.rigidity.RigidityConfig`, or its fields) the distance-invariance test across frames
    (seed 001 eq. 2) on the four-view tracks the track filter kept: keyframe stereo points against the current
    frame's; flagged tracks leave the view; ``disparity_offset`` (:class:`~vo.estimators.disparity_offset.
    OffsetConfig`, or its fields) the online estimate of a right principal-point error (:mod:`vo.rop.offset`)."""

    name = "rop"

    def __init__(self, rig, config: RopConfig | None = None, uncertainty: UncertaintyModel | None = None,
                 tracker=None, step_observer=None, rigidity=None, disparity_offset=None, **options):
        super().__init__(rig, **options)
        if config is not None and options:
            raise EstimatorError(f"rop: give either config or options, not both (options {sorted(options)})")
        if not rig.is_stereo:
            raise EstimatorError(f"rop: rig {rig.name!r} has one camera; seed 000 needs a stereo rig")
        self.config = c = config if config is not None else RopConfig.from_options(options)
        self.cams = rig.cameras[:2]
        self.focal = float(np.mean([cam.fx for cam in self.cams] + [cam.fy for cam in self.cams]))
        self.T_c1_c2 = rig.T_c0_c1
        self.baseline = float(np.linalg.norm(self.T_c1_c2[:3, 3]))
        self.adjustment_config = AdjustmentConfig()
        self.uncertainty = uncertainty if uncertainty is not None else make_uncertainty(c, self.adjustment_config,
                                                                                        self.focal)
        if tracker is not None and c.frontend != "klt":
            raise EstimatorError(f"rop: a tracker is the KLT front-end's; frontend is {c.frontend!r}")
        self.klt = (tracker if tracker is not None else KltFourView(rig, c.klt_config, c.klt_refine, c.zncc_texture_snr)
                    ) if c.frontend == "klt" else None
        self.step_observer = step_observer
        self.rigidity = RigidityConfig.from_option(rigidity, "rop.rigidity")
        self._rigidity_rng = np.random.default_rng(self.rigidity.seed)   # partner draws
        self.offset = RopOffset.of(rig, disparity_offset, self.klt)     # None: no estimate
        self.track_filter_config = f = PnpConfig(ransac_reproj_px=c.moving_reproj_px,
                                                 min_model_fraction=c.moving_min_fraction)
        self.rotation_tester = RotationTester(c.pnp_rotation_prob, c.moving_reproj_px, f.max_depth,
                                              f.max_triangulation_px)
        self.T_o_c0, self.cov, self.T_o_kf, self.cov_kf = np.eye(4), np.zeros((6, 6)), np.eye(4), np.zeros((6, 6))
        self._kf_imgs = None          # (left, right) of the keyframe; None before the first frame
        self._t_kf, self._n_kf = None, 0
        self._T_kf_cur, self._last_motion = np.eye(4), np.eye(4)
        self._lost, self._n_coast, self._n_solved = False, 0, 0
        self._filter = TrackFilter(None)                       # the track filter's verdict on this frame
        self._T_kf_pnp, self._pnp_motion = np.eye(4), np.eye(4)   # PnP chain: pose in the keyframe, last step
        self.epochs: list[EpochRecord] = []   # one per frame solved against its keyframe (Fig. 5 check)

    # ------------------------------------------------------------------------------ front-end
    def _new_keyframe(self, left, right, t_ns: int, timings, keep_tracks: bool) -> int:
        self.T_o_kf, self.cov_kf, self._T_kf_cur = self.T_o_c0.copy(), self.cov.copy(), np.eye(4)
        self._T_kf_pnp = np.eye(4)
        self._kf_imgs, self._t_kf = (left, right), t_ns
        self._n_kf = self.klt.keyframe(left, right, timings, keep_tracks) if self.klt is not None else 1
        return self._n_kf

    def _pairs(self, left, right, timings) -> tuple:
        """-> ({pair: (x_i, x_j)}, usable features, median keyframe disparity (px), FourView or None)."""
        if self.klt is not None:
            v = self.klt.track(left, right, timings, self._track_guess())
            v = self._rigid_tracks(self._static_tracks(v, timings), timings)
            disp = np.median(np.linalg.norm(v.x1 - v.x2, axis=1)) * self.focal if len(v) else 0.0
            return {p: v.pair(p) for p in PAIRS}, int(v.ok4.sum()), float(disp), v
        t0 = time.perf_counter()
        kl, kr = self._kf_imgs
        pairs = matching.descriptor_pairs({1: kl, 2: kr, 3: left, 4: right}, self.cams, self.config.frontend)
        timings["track"] += (time.perf_counter() - t0) * 1e3
        return pairs, min(len(a) for a, _ in pairs.values()), 0.3 * self.focal, None

    def _prior(self) -> np.ndarray:
        """Constant-velocity prediction ``T_kf_c`` of this frame that selects the motion (``moving_prior``)."""
        if self.config.moving_prior == "pnp":
            return self._T_kf_pnp @ self._pnp_motion
        return self._T_kf_cur @ self._last_motion

    def _track_guess(self):
        """Indices -> those tracks' left pixels at :meth:`_prior` (``predict_tracks``, :mod:`vo.rop.track_start`)."""
        v, f = self.klt.view, self.track_filter_config
        if not (self.config.predict_tracks and self._n_solved and v is not None):
            return None
        return lambda i: predicted_left(self.rig, self._prior(), v.p1[i], v.x1[i], v.p2[i], v.p3[i], f.max_depth,
                                        f.max_triangulation_px)

    def _static_tracks(self, v, timings):
        """With ``moving_objects="prior"``: drop the tracks of rigid motions other than the one nearest the
        prior (:mod:`vo.rop.moving`); the kept view replaces the tracker's."""
        self._filter = TrackFilter(None)
        if self.config.moving_objects == "none" or len(v) == 0:
            return v
        t0 = time.perf_counter()
        self._filter = f = filter_tracks(v, self.rig, self._prior(), self.track_filter_config)
        if self.offset is not None:
            self.offset.filtered(v.ids, f.inliers)
        if f.keep is not None:          # fewer than min_matches left: a failed frame (coasts), not the car's motion
            v = self.klt.view = v.subset(f.keep)
        timings["track"] += (time.perf_counter() - t0) * 1e3
        return v

    def _rigid_tracks(self, v, timings):
        """With ``rigidity.enabled``: drop the four-view tracks whose keyframe and current stereo points break the
        distance invariance with most partners (:mod:`vo.estimators.rigidity`); the kept view replaces the
        tracker's. Tracks without a current right point, or that do not triangulate, stay untested."""
        if not self.rigidity.enabled or len(v) == 0:
            return v
        t0 = time.perf_counter()
        c = self.track_filter_config
        p_a, ok_a = triangulate(self.rig, v.p1, v.p2, c.max_depth, c.max_triangulation_px)
        p_b, ok_b = triangulate(self.rig, v.p3, v.p4, c.max_depth, c.max_triangulation_px)
        sel = np.flatnonzero(v.ok4 & ok_a & ok_b)
        keep = np.ones(len(v), bool)
        keep[sel] = rigid_subset(p_a[sel], np.zeros(3), p_b[sel], np.zeros(3), self.focal, self.baseline,
                                 self.rigidity, self._rigidity_rng)
        if not keep.all():
            v = self.klt.view = v.subset(keep)
        timings["track"] += (time.perf_counter() - t0) * 1e3
        return v

    def _pnp_pose(self) -> np.ndarray | None:
        """The track filter's PnP pose ``T_kf_c`` when it may stand for the frame's: >= :data:`MIN_COAST_PNP_INLIERS`
        inliers and within ``moving_prior_gate_m`` of the prediction (unless that rests on no solved frame or on a
        held pose) - a car's motion as the only candidate (crossing traffic) is far from it. Else None."""
        trusted = self._n_solved > 0 and self._n_coast < MAX_COAST_FRAMES
        return self._filter.frame_pose(trusted, self.config.moving_prior_gate_m, MIN_COAST_PNP_INLIERS)

    def _weak_pose(self) -> np.ndarray | None:
        """A failed frame's pose ``T_kf_c`` from a small PnP fit of the keyframe's stereo tracks when it is well
        conditioned and near the prediction (:mod:`vo.rop.weak_frame`; before a rotation-only fit); else None."""
        if self.klt is None or self.klt.view is None or self._n_solved == 0:
            return None
        c = self.config
        w = weak_frame_pose(self.klt.view, self.rig, self._prior(), c.moving_reproj_px, c.moving_prior_gate_m)
        return w.T_kf_c if w is not None and w.ok else None

    def _step_miss(self, T_kf_c: np.ndarray) -> str:
        """Why the ROP step ``T_kf_c`` is suspect ("" when it is not): farther than ``moving_step_gate_m`` from the
        track filter's PnP pose of the same tracks when the filter saw competing rigid motions; with one rigid
        motion (a scale disagreement only, e.g. a calibration error: docs/estimators.md, "Real recordings"),
        only when also off by more than :data:`vo.rop.moving.GROSS_STEP_FRACTION` of the step."""
        if self.config.moving_objects == "none":
            return ""
        return self._filter.step_miss(T_kf_c, self._pnp_pose(), self.config.moving_step_gate_m)

    def _rotation_miss(self, T_kf_c: np.ndarray, cov_step: np.ndarray) -> str:
        """Why the ROP step's rotation is suspect ("" when it is not): it differs from the track filter's PnP pose
        of the same tracks beyond ``pnp_rotation_test`` (:class:`vo.rop.rotation_test.RotationTester` in both
        fits' covariances, or :func:`vo.rop.weak_frame.rotation_miss` in degrees)."""
        if self.config.moving_objects == "none":
            return ""
        if self.config.pnp_rotation_test == "degrees":
            return rotation_miss(T_kf_c, self._pnp_pose(), self.config.pnp_rotation_gate_deg)
        view = self.klt.view if self.klt else None
        return self.rotation_tester.miss(T_kf_c, cov_step, self._pnp_pose(), view, self.rig)

    def _advance_prior(self, T_kf_c: np.ndarray) -> None:
        """Extend the PnP chain of the prediction by this frame (its PnP pose, else the frame's own)."""
        T = T_pnp if (T_pnp := self._pnp_pose()) is not None else T_kf_c
        self._pnp_motion, self._T_kf_pnp = inv_T(self._T_kf_pnp) @ T, T.copy()

    # ------------------------------------------------------------------------------- solving
    def _rotation_only_step(self, R_1_3, parallax, n, disparity) -> tuple:
        return rotation_only_step(R_1_3, parallax, n, disparity, self.focal, self.baseline, self.config.min_parallax_px)

    def rop_set(self, pairs, R_1_3, priors):
        """The four ROPs of one step from its pairs (``{pair: (x_i, x_j)}``), the rotation-only ``R_1_3`` and
        the predicted ROPs ``priors``, after the rotation consensus (:mod:`vo.rop.consensus`)."""
        return rotation_consensus(solve_rops(pairs, priors, self.focal, self.T_c1_c2, self.config), R_1_3,
                                  self.config.max_rop_rotation_deg)

    def solve_step(self, pairs, R_1_3, priors):
        """``T_kf_c`` (4,4) of one step solved from the inputs a ``step_observer`` receives (ROPs, consensus,
        adjustment), None when the adjustment fails; the estimator's state is not touched."""
        return self._adjust(self.rop_set(pairs, R_1_3, priors), dict(essential=0.0, initial=0.0, adjust=0.0))[0]

    def _adjust(self, ropset, timings) -> tuple:
        """-> (T_kf_c, cov_step, epoch, message); T None on failure."""
        if len(ropset.ok_pairs) < 3:
            msgs = "; ".join(f"{p}: {m.message}" for p, m in ropset.rops.items() if not m.ok)
            return None, None, None, f"{len(ropset.ok_pairs)} of 4 ROPs usable ({msgs or 'too few matches'})"
        t1 = time.perf_counter()
        init = initial_eops(ropset)
        minimal = initial_eops(ropset, mode="minimal")          # the paper's simplest reading (Fig. 5 check)
        t2 = time.perf_counter()
        res = adjust_rops(ropset, init, self.adjustment_config)
        timings["initial"] += (t2 - t1) * 1e3
        timings["adjust"] += (time.perf_counter() - t2) * 1e3
        cov = res.cov_propagated if res.cov_propagated is not None else res.cov_apost
        epoch = ("rops", init.T_c1_c3, None if minimal.degenerate else minimal.T_c1_c3, ropset, res)
        if res.degenerate or cov is None or not np.all(np.isfinite(res.T_c1_c3)) or not np.all(np.isfinite(cov)):
            return None, None, epoch, f"degenerate ROP geometry: {res.message or 'no redundancy'}"
        return res.T_c1_c3, cov, epoch, ""

    def _step(self, pairs, disparity, timings) -> tuple:
        """-> (T_kf_c, cov_step, epoch, message, R_1_3 of the rotation-only fit or None); T None on failure."""
        t0 = time.perf_counter()
        x1, x3 = pairs["13"]
        R_1_3, parallax, _ = rotation_only(x1, x3, self.focal)
        R_rot = R_1_3 if len(x1) >= MIN_ROTATION_TRACKS else None
        min_par = self.config.min_parallax_px
        if parallax < min_par:
            timings["essential"] += (time.perf_counter() - t0) * 1e3
            return (*self._rotation_only_step(R_1_3, parallax, len(x1), disparity),
                    f"parallax {parallax:.2f} px < {min_par} px: no translation (rotation only)", R_rot)
        priors = predicted_rops(R_1_3, (self._T_kf_cur @ self._last_motion)[:3, 3], self.T_c1_c2)
        if self.step_observer is not None:
            self.step_observer(pairs, R_1_3, priors)
        ropset = self.rop_set(pairs, R_1_3, priors)
        timings["essential"] += (time.perf_counter() - t0) * 1e3
        T, cov, epoch, msg = self._adjust(ropset, timings)
        if T is None and parallax < 2.0 * min_par:
            return (*self._rotation_only_step(R_1_3, parallax, len(x1), disparity),
                    f"parallax {parallax:.2f} px, {msg}: rotation only", R_rot)
        return T, cov, epoch, msg, R_rot

    def _is_keyframe(self, T_kf_c, n_feat) -> bool:
        c = self.config
        return bool(np.linalg.norm(T_kf_c[:3, 3]) >= c.keyframe_baseline_ratio * self.baseline
                    or n_feat < max(2 * c.min_matches, c.keyframe_min_track_ratio * self._n_kf))

    def _record_epoch(self, t_ns: int, T_kf_c: np.ndarray, epoch) -> None:
        kind, T_init, T_min, ropset, _ = epoch
        ok = ropset.ok_pairs if ropset is not None else ()
        n = {p: ropset.rops[p].n_inliers for p in ok}
        rops = {p: (ropset.rops[p].R_i_j, ropset.rops[p].rhat_i_j) for p in ok}
        self.epochs.append(EpochRecord(self._t_kf, t_ns, kind, T_init, T_kf_c.copy(), T_min, n, rops))

    # ------------------------------------------------------------------------------- frames
    def _result(self, frame, status, n_feat, n_inl, msg, timings, t0, pose_class="ok") -> FrameResult:
        if self.offset is not None:      # the frame's pose is set: feed the offset estimate (vo.rop.offset)
            self.klt.right_shift_px = self.offset.frame(self.klt.view, self.T_o_c0, self.klt.right_shift_px)
        timings["total"] = (time.perf_counter() - t0) * 1e3
        return FrameResult(frame.t_ns, self.T_o_c0.copy(), status, int(n_feat), int(n_inl), self.cov.copy(), msg,
                           timings, pose_class)

    def _fail(self, frame, left, right, status, n_feat, msg, timings, t0, R_1_3=None,
              keep_tracks=False, lost=True) -> FrameResult:
        """The track filter's PnP pose when it may stand for the frame's (:meth:`_pnp_pose`); else coast: the
        rotation-only fit's rotation when there was one (tracks survive a failed ROP solve), the translation
        extrapolated at constant velocity (held after :data:`MAX_COAST_FRAMES`); then a fresh keyframe. The pose's class
        (:data:`~vo.estimators.base.FRAME_CLASSES`): ok from PnP, coasting when extrapolated, lost when held.
        ``lost=False`` (a ROP step replaced by the PnP pose, :meth:`_rotation_miss`): the next frame is no re-init."""
        T_prev = self.T_o_c0
        coast = self._n_coast < MAX_COAST_FRAMES
        T_step = self._T_kf_cur @ self._last_motion if coast else self._T_kf_cur.copy()
        T_pnp, source = self._pnp_pose(), "the track filter's PnP"
        if T_pnp is None:
            T_pnp, source = self._weak_pose(), "a well-conditioned PnP of the keyframe's stereo tracks"
        if T_pnp is not None:
            T_step, R_1_3 = T_pnp, None
        elif R_1_3 is not None:
            T_step = make_T(R_1_3, T_step[:3, 3])
        self._advance_prior(T_step)
        T_new = self.T_o_kf @ T_step
        if np.all(np.isfinite(T_new)):
            self.T_o_c0 = T_new
        self._last_motion = inv_T(T_prev) @ self.T_o_c0
        self._n_coast += int(lost)
        self.uncertainty.reset(self.T_o_c0, self.cov)
        self._new_keyframe(left, right, int(frame.t_ns), timings, keep_tracks=keep_tracks)
        self._lost = lost
        if T_pnp is not None:
            msg += f"; pose from {source}, new keyframe"
        else:
            msg += ("; rotation from the rotation-only fit" if R_1_3 is not None else "") + "; translation " + \
                   ("extrapolated (constant velocity)" if coast else "held") + ", re-initialising from this frame"
        pose_class = "ok" if T_pnp is not None else ("coasting" if coast else "lost")
        return self._result(frame, status, n_feat, 0, msg, timings, t0, pose_class)

    def process(self, frame: StereoFrame) -> FrameResult:
        t0 = time.perf_counter()
        timings = dict.fromkeys(STAGES, 0.0)
        left, right = to_gray(frame.left), to_gray(frame.right)
        if self._kf_imgs is None:
            n = self._new_keyframe(left, right, int(frame.t_ns), timings, keep_tracks=False)
            return self._result(frame, "init", n, 0, "first frame defines O", timings, t0)
        pairs, n_feat, disparity, tracks = self._pairs(left, right, timings)
        if n_feat < self.config.min_matches:
            x1, x3 = pairs["13"]
            R_rot = rotation_only(x1, x3, self.focal)[0] if len(x1) >= MIN_ROTATION_TRACKS else None
            return self._fail(frame, left, right, "few_features", n_feat, f"{n_feat} four-view features < "
                              f"{self.config.min_matches}: texture-poor view?", timings, t0, R_rot)
        T_kf_c, cov_step, epoch, msg, R_rot = self._step(pairs, disparity, timings)
        if T_kf_c is None:
            return self._fail(frame, left, right, "lost", n_feat, msg, timings, t0, R_rot)
        miss = self._step_miss(T_kf_c) if epoch[0] == "rops" else ""
        if miss:
            return self._fail(frame, left, right, "lost", n_feat, miss, timings, t0,
                              keep_tracks=True)
        miss = self._rotation_miss(T_kf_c, cov_step) if epoch[0] == "rops" else ""
        act = self.config.pnp_rotation_action
        T_fix = readjusted_step(epoch[3], epoch[4], self._pnp_pose()[:3, :3], self.adjustment_config,
                                self._pnp_pose()[:3, 3] if act == "direction" else None) \
            if miss and act != "pose" else None
        if miss and T_fix is None:
            return self._fail(frame, left, right, "keyframe", n_feat, miss, timings, t0, keep_tracks=True, lost=False)
        if miss:
            T_kf_c, msg = T_fix, "; ".join(filter(None, (msg, miss + ": its rotation, translation re-adjusted")))
        if not miss:                       # a step the rotation test corrected is no ROP epoch (Fig. 5 check)
            self._record_epoch(frame.t_ns, T_kf_c, epoch)
        is_kf = self._is_keyframe(T_kf_c, n_feat)
        step = Step(int(frame.t_ns), self.T_o_kf, self.cov_kf, T_kf_c, cov_step, is_kf, epoch[3], epoch[4], pairs,
                    tracks, (*self._kf_imgs, left, right))
        t1 = time.perf_counter()
        self.cov = self.uncertainty.on_step(step)
        timings["adjust"] += (time.perf_counter() - t1) * 1e3
        T_prev, self.T_o_c0 = self.T_o_c0, step.T_o_c
        self._last_motion, self._T_kf_cur, self._n_coast = inv_T(T_prev) @ self.T_o_c0, T_kf_c, 0
        self._advance_prior(T_kf_c)
        self._n_solved += 1
        status = "ok"
        if self._lost:
            status, msg, self._lost = "reinit", ("re-initialised after a failed frame; " + msg).rstrip("; "), False
        if is_kf:
            self._new_keyframe(left, right, int(frame.t_ns), timings, keep_tracks=True)
            status = "keyframe" if status == "ok" else status
        return self._result(frame, status, n_feat, n_feat, msg, timings, t0)
