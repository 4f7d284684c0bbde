"""Conventional stereo VO of seed 003: stereo triangulation on keyframes, 3-D-to-2-D PnP + RANSAC each frame.

``KltPnpEstimator`` ("klt-pnp"): KLT tracks (grid detection, LK forward-backward, epipolar check), new landmarks
from empty cells on keyframes, seed 003's empty-cell / inlier keyframe criterion (the *next* frame is one).
``StereoPnpEstimator`` (:mod:`vo.estimators.stereo_pnp`: (re)initialisation, failure statuses, coasting) is the
frame loop it shares with ``orb-pnp``; ``klt-pnp`` turns a coasted step by the rotation-only fit of its
frame-to-frame tracks (``coast_rotation``). Timings (ms per frame): ``detect``, ``track``, ``stereo``, ``pnp``,
``total``.

Moving objects (our extension): each frame's PnP takes, among the rigid motions the landmarks hold, the one nearest
the constant-velocity prediction (``pnp_config.consensus="prior"``; ``pnp_core``), not RANSAC's largest consensus.
Stereo disparity offset (``klt-pnp``; not in seed 003): a calibration whose right principal point is off the images'
(the real KITTI excerpt: about 1.2-1.4 px) makes every step long; the offset is estimated online from the tracks and,
where significant, landmark depths are corrected along their birth rays (``disparity_offset``) and the frames since
the (re)initialisation re-chained (``offset_replay``); with a consistent calibration nothing changes. The temporal
LK starts at each landmark's constant-velocity prediction (``track_prediction``; not in seed 003). The close/far
split (ORB-SLAM2's rule, ``near_far``) is off by default (``pnp_config={near_baselines: 40}``). Simplifications
against seed 003: no bundle adjustment (landmarks keep their birth keyframe's triangulation; no left-right re-match
on later keyframes); PnP outliers leave the tracks (``klt-pnp``: beyond ``disparity_offset.track_gate_px``,
``track_gate``).
"""
from __future__ import annotations

import numpy as np

from vo.errors import EstimatorError
from vo.estimators.base import FrameResult
from vo.estimators.coast_rotation import coast_rotation
from vo.estimators.disparity_offset import DisparityOffset, OffsetConfig
from vo.estimators.near_far import NearFarGate, refine_on_near
from vo.estimators.offset_replay import ChainRecord, rebased_near
from vo.estimators.rigidity import RigidityConfig, refine_pose, rigid_subset
from vo.estimators.stage_timing import timed
from vo.estimators.stereo_pnp import StereoPnpEstimator
from vo.estimators.track_gate import OffsetOnlyTracks, kept_tracks
from vo.estimators.track_prediction import track_guess
from vo.frontend.depth_edge import off_edge
from vo.frontend.klt import KltConfig, KltTracker, is_keyframe, stereo_klt
from vo.frontend.stereo import triangulate, undistort_px
from vo.frontend.stereo_prior import disparity_guess, landmark_refs
from rigs.geometry import inv_T, transform_points
from rigs.geometry.pinhole import to_normalized


class KltPnpEstimator(StereoPnpEstimator):
    """Seed 003's optical-flow stereo VO. Options: ``klt_config`` (:class:`KltConfig`), ``pnp_config``.
    Collaborators (default: the product's): ``tracker``, a :class:`KltTracker` (or one that behaves as it);
    ``landmark_source(left, right, ids (N,), p_l (N, 2)) -> (p_c0 (N, 3), ok (N,))``, the landmarks of new tracks in
    the current left camera (default: stereo KLT, the depth-edge test, triangulation); ``keyframe_adjuster``
    (default none: seed 003 without its keyframe optimization), an object with ``reset()`` and ``adjust(left, right,
    T_o_c0 (4,4), ids (N,), px (N,2), landmarks {id: p_o (3,)} of the tracked ids) -> (T_o_c0 (4,4), landmarks {id:
    p_o (3,)}, rejected ids)``, called on every keyframe before its new tracks are triangulated
    (``docs/studies/keyframe_ba.py`` supplies a windowed bundle adjustment). ``disparity_offset``
    (:class:`OffsetConfig`): the online stereo disparity-offset estimate (:mod:`vo.estimators.disparity_offset`)
    that corrects landmark depths under an inconsistent calibration; ``offset``, the estimate itself (a
    :class:`DisparityOffset` or one that behaves as it; default: built from ``disparity_offset``). ``rigidity``
    (:class:`~vo.estimators.rigidity.RigidityConfig`, or its fields; off by default, measured in
    ``docs/estimators.md``): the distance-invariance test across frames (seed 001 eq. 2) on each frame's PnP
    inliers, their birth positions against a fresh stereo match; the flagged landmarks leave the inliers and the
    pose is refined without them; ``rigidity_observer(px (M,2), kept (M,) bool)`` (studies) receives the left pixels
    of the inliers it tested and its verdict."""

    name = "klt-pnp"

    def __init__(self, rig, klt_config: KltConfig | None = None, frontend: str = "klt", tracker=None,
                 landmark_source=None, keyframe_adjuster=None, disparity_offset: OffsetConfig | None = None,
                 offset=None, rigidity=None, rigidity_observer=None, **options):
        if frontend != "klt":
            raise EstimatorError(f"klt-pnp: frontend {frontend!r} not supported; valid: klt (use orb-pnp for orb, sift)")
        super().__init__(rig, **options)
        self.klt_config = KltConfig.from_option(klt_config, f"{self.name}.klt_config")
        cam = rig.cameras[0]
        self.tracker = tracker if tracker is not None else KltTracker(cam.width, cam.height, self.klt_config)
        self.landmark_source = landmark_source if landmark_source is not None else self._stereo_landmarks
        self.keyframe_adjuster = keyframe_adjuster
        self.landmarks: dict = {}        # track id -> p_o (3,)
        self.near: dict = {}             # track id -> (near at birth, birth c_o (3,), birth bearing_o (3,))
        self._next_keyframe = False
        self._gate = NearFarGate(self.pnp_config, float(cam.K[0, 0]), rig.baseline)
        offset_config = OffsetConfig.from_option(disparity_offset, f"{self.name}.disparity_offset")
        self.offset = offset if offset is not None else DisparityOffset(offset_config, float(cam.K[0, 0]), rig.baseline)
        self._raw: dict = {}             # track id -> p_o (3,) as triangulated (before the offset's correction)
        self._offset_only = OffsetOnlyTracks()   # tracks the offset estimate sees but the pose does not
        self._applied_offset = 0.0
        self._replayed_offset = 0.0      # the offset the recorded chain was last re-chained with
        self._chain = ChainRecord(offset_config.replay_frames if keyframe_adjuster is None else 0)
        self.rigidity = RigidityConfig.from_option(rigidity, f"{self.name}.rigidity")
        self._rigidity_rng = np.random.default_rng(self.rigidity.seed)   # partner draws
        self.rigidity_observer = rigidity_observer

    def _initialize(self, left, right, timings) -> int:
        self.tracker.reset()
        self.landmarks.clear()
        self.near.clear()
        self._raw.clear()
        self._offset_only.reset()
        self._chain.reset()
        if self.keyframe_adjuster is not None:
            self.keyframe_adjuster.reset()
        with timed(timings, "detect"):
            new_ids = self.tracker.detect(left)
        n = self._add_landmarks(left, right, new_ids, timings)
        if self.offset.config.enabled:
            self._chain.frame(self.T_o_c0, np.zeros(0, np.int64), np.zeros((0, 2)))
        if n < self.pnp_config.min_init_landmarks:    # failed: every corner stays, for the next frame's rotation fit
            with timed(timings, "detect"):
                self.tracker.detect(left)
        self._next_keyframe = False
        return n

    def _add_landmarks(self, left, right, new_ids, timings) -> int:
        """Stereo-match the tracks ``new_ids``, triangulate, keep those with a landmark; returns the count added."""
        if self.keyframe_adjuster is not None:
            with timed(timings, "ba"):
                self._adjust_keyframe(left, right)
        with timed(timings, "stereo"):
            sel = np.isin(self.tracker.ids, new_ids)
            p_l = self.tracker.pts[sel]
            p_c0, ok = self.landmark_source(left, right, self.tracker.ids[sel], p_l)
            p_o = transform_points(self.T_o_c0, p_c0)
            z_c0 = transform_points(inv_T(self.T_o_c0), p_o)[:, 2]
            cam = self.rig.cameras[0]
            x_n = to_normalized(undistort_px(p_l, cam), cam.K)
            dir_o = (self.T_o_c0[:3, :3] @ np.c_[x_n, np.ones(len(x_n))].T).T
            self.offset.add(self.tracker.ids[sel][ok], self.T_o_c0[:3, 3], dir_o[ok], z_c0[ok])
            if self.offset.config.enabled:
                self._chain.born(self.tracker.ids[sel][ok], p_c0[ok])
            if self.offset.delta_px != 0.0:
                fb = self.offset.fb
                z_c0 = np.where(ok, fb / (fb / np.where(ok, z_c0, 1.0) + self.offset.delta_px), z_c0)
            near = z_c0 < self.pnp_config.near_baselines * self.rig.baseline
            for i, p, c, d in zip(self.tracker.ids[sel][ok], p_o[ok], near[ok], dir_o[ok]):
                self._raw[int(i)] = p
                self.landmarks[int(i)] = self.offset.correct(int(i), p)
                self.near[int(i)] = (bool(c), self.T_o_c0[:3, 3].copy(), d)
            self.tracker.keep(np.array([i in self.landmarks for i in self.tracker.ids.tolist()], bool))
        return int(ok.sum())

    def _adjust_keyframe(self, left, right) -> None:
        """Let the keyframe adjuster move this keyframe's pose and the landmarks, and drop those it rejects."""
        ids = self.tracker.ids
        tracked = {int(i): self.landmarks[int(i)] for i in ids if int(i) in self.landmarks}
        T_new, landmarks, rejected = self.keyframe_adjuster.adjust(left, right, self.T_o_c0, ids, self.tracker.pts,
                                                                   tracked)
        self.landmarks = {int(i): p for i, p in landmarks.items() if i not in rejected}
        self.near = {i: v for i, v in self.near.items() if i in self.landmarks}
        T_o_prev = self.T_o_c0 @ inv_T(self._T_prev_curr)
        self.T_o_c0, self._T_prev_curr = T_new, inv_T(T_o_prev) @ T_new

    def _stereo_landmarks(self, left, right, ids, p_l) -> tuple:
        """The product's landmark source: stereo KLT (with ``klt_config.stereo_prior``, started for the corners it
        loses from zero disparity at the disparity of the nearest landmarks: :mod:`vo.frontend.stereo_prior`),
        the depth-edge test, triangulation in the left camera."""
        known = self._offset_only.pose_all(self.tracker.ids) & np.isin(self.tracker.ids, list(self.landmarks))
        p_known = np.array([self.landmarks[int(i)] for i in self.tracker.ids[known]]).reshape(-1, 3)
        prior = disparity_guess(p_l, *landmark_refs(self.rig, inv_T(self.T_o_c0), p_known, self.tracker.pts[known])) \
            if self.klt_config.stereo_prior else None
        p_r, ok = stereo_klt(left, right, p_l, self.rig, self.klt_config, self.tracker.pyramid, prior)
        if ok.any():
            ok[ok] &= off_edge(left, right, p_l[ok], p_r[ok], self.klt_config)
        p_c0, ok_t = triangulate(self.rig, p_l, p_r, self.pnp_config.max_depth, self.pnp_config.max_triangulation_px)
        return p_c0, ok & ok_t

    def _coast_rotation(self, left, timings):
        """The rotation-only fit (:mod:`vo.estimators.coast_rotation`) of the tracker's points tracked into
        ``left`` (a frame about to re-initialise), None without enough tracks."""
        if self.tracker.image is None or len(self.tracker.pts) == 0:
            return None
        p_prev = self.tracker.pts.copy()
        with timed(timings, "track"):
            alive = self._track(left)
        return coast_rotation(*self._offset_only.pose_rows(self.tracker.ids, p_prev[alive], self.tracker.pts),
                              self.rig.cameras[0])

    def _track(self, left) -> np.ndarray:
        """The tracker into ``left``, its LK started at the landmarks' constant-velocity prediction
        (:mod:`vo.estimators.track_prediction`; ``pnp_config.predict_tracks``) -> the survival mask."""
        if not self.pnp_config.predict_tracks or len(self.tracker.pts) == 0:
            return self.tracker.track(left)
        return self.tracker.track(left, track_guess(self.rig.cameras[0], self.predicted_T_o_c0, self.landmarks,
                                                    self.tracker.ids, self.tracker.pts))

    def _step(self, t_ns, left, right, timings) -> FrameResult:
        p_prev = self.tracker.pts.copy()
        with timed(timings, "track"):
            alive = self._track(left)
            ids = self.tracker.ids
            self.landmarks = {i: self.landmarks[i] for i in ids.tolist()}
        use = self._offset_only.pose_all(ids)
        n_feat, n_pose = len(ids), int(use.sum())          # all tracks; those that may define the pose (use)
        R_track = lambda: coast_rotation(p_prev[alive][use], self.tracker.pts[use], self.rig.cameras[0])  # noqa: E731
        if n_pose < self.pnp_config.min_features:
            return self._fail(t_ns, "few_features", n_feat, 0, f"{n_pose} tracked < {self.pnp_config.min_features}",
                              R_track())
        p_o = np.array([self.landmarks[i] for i in ids.tolist()])
        T_o_c0, inl = self._pnp(p_o, self.tracker.pts, timings, None if use.all() else use)
        if T_o_c0 is not None and (self.pnp_config.near_baselines > 0 or self.rigidity.enabled):
            near = np.array([self.near[int(i)][0] for i in ids], bool)
            rays = tuple(np.array([self.near[int(i)][k] for i in ids]).reshape(-1, 3) for k in (1, 2))
            if self.rigidity.enabled:
                T_o_c0, inl = self._rigid(left, right, T_o_c0, inl, p_o, rays[0], timings)
        if T_o_c0 is not None and self.pnp_config.near_baselines > 0:
            T_o_c0, inl = self._near_far(T_o_c0, inl, p_o, near, rays, timings)
        n_inl = int(inl.sum())
        if T_o_c0 is None or not self._accept_pose(T_o_c0):
            return self._fail(t_ns, "lost", n_feat, n_inl, f"PnP failed: {n_inl} inliers of {n_feat} tracked",
                              R_track())
        kept = kept_tracks(T_o_c0, p_o, self.tracker.pts, inl, self.rig.cameras[0], self.offset.config)
        self.tracker.keep(self._offset_only.keep(ids, inl, kept, self.offset.pending_ids()))
        status, msg = "ok", ""
        if self._next_keyframe:
            with timed(timings, "detect"):
                new_ids = self._offset_only.detect(self.tracker, left)
            n_new = self._add_landmarks(left, right, new_ids, timings)
            status, msg = "keyframe", f"{n_new} new landmarks"
        self.landmarks = {i: self.landmarks[i] for i in self.tracker.ids.tolist()}
        self.near = {i: self.near[i] for i in self.landmarks}
        self._update_offset()
        self._next_keyframe = is_keyframe(self._offset_only.empty_fraction(self.tracker), n_inl, self.klt_config)
        return self._result(t_ns, status, n_feat, n_inl, msg)

    def _update_offset(self) -> None:
        """Feed the tracked (inlier) landmarks to the disparity-offset estimate; when the offset it applies
        changes, move every tracked landmark to its corrected depth."""
        if not self.offset.config.enabled:
            return
        self._raw = {i: self._raw[i] for i in self.landmarks}
        self.offset.forget(self.landmarks)
        cam = self.rig.cameras[0]
        pts = self.tracker.pts
        px = undistort_px(pts, cam)
        x_n = to_normalized(px, cam.K)
        self._chain.frame(self.T_o_c0, *self._offset_only.pose_tracks(self.tracker.ids, px))
        self.offset.observe(self.tracker.ids, x_n, self.T_o_c0, self._offset_only.pose_all(self.tracker.ids))
        if self.offset.delta_px != self._applied_offset:
            if abs(self.offset.delta_px - self._replayed_offset) > self.offset.config.replay_step_px:
                self._replay_chain()
            self._applied_offset = self.offset.delta_px
            self.landmarks = self.offset.correct_all({i: self._raw[i] for i in self.landmarks})

    def _replay_chain(self) -> None:
        """The applied offset moved by more than ``replay_step_px``: re-chain the frames recorded since the
        (re)initialisation with its depths (:mod:`vo.estimators.offset_replay`); the current pose, velocity, step
        history, raw landmark positions and the offset estimate's stored poses move to the re-chained ones."""
        self._replayed_offset = self.offset.delta_px
        replay = self._chain.replay(self.offset.delta_px, self.offset.fb, self.rig.cameras[0].K)
        if replay is None:
            return
        self.T_o_c0 = replay.pairs[-1][1].copy()
        self._T_prev_curr = inv_T(replay.pairs[-2][1]) @ replay.pairs[-1][1]
        self._steps.rebase([T_new for _, T_new in replay.pairs])
        self._raw = {i: replay.raw_o.get(i, p) for i, p in self._raw.items()}
        moved = replay.moved()
        self.offset.rebase(moved)
        self.near = rebased_near(self.near, moved)

    def _rigid(self, left, right, T_o_c0, inl, p_o, c_o, timings) -> tuple:
        """The rigidity test (:mod:`vo.estimators.rigidity`) on the PnP inliers: birth positions ``p_o`` (N,3)
        seen from their keyframes' centres ``c_o`` (N,3) against this frame's stereo points; flagged inliers
        become outliers (dropped from the tracks) and the pose is refined on the rest. Inliers without a stereo
        match this frame stay untested."""
        cam, c = self.rig.cameras[0], self.pnp_config
        with timed(timings, "stereo"):
            idx = np.flatnonzero(inl)
            p_l = self.tracker.pts[idx]
            p_r, ok = stereo_klt(left, right, p_l, self.rig, self.klt_config, self.tracker.pyramid)
            p_c, ok_t = triangulate(self.rig, p_l, p_r, c.max_depth, c.max_triangulation_px)
            sel = idx[ok & ok_t]
            keep = rigid_subset(p_o[sel], c_o[sel], p_c[ok & ok_t], np.zeros(3), float(cam.K[0, 0]),
                                self.rig.baseline, self.rigidity, self._rigidity_rng)
        if self.rigidity_observer is not None:
            self.rigidity_observer(self.tracker.pts[sel].copy(), keep.copy())
        drop = sel[~keep]
        inl_kept = inl.copy()
        inl_kept[drop] = False
        if len(drop) == 0 or inl_kept.sum() < c.min_pnp_inliers:
            return T_o_c0, inl
        with timed(timings, "pnp"):
            T_c0_o = refine_pose(inv_T(T_o_c0), p_o[inl_kept], undistort_px(self.tracker.pts[inl_kept], cam), cam.K)
        return inv_T(T_c0_o), inl_kept

    def _near_far(self, T_o_c0, inl, p_o, near, rays, timings) -> tuple:
        """The close/far split's pose and inliers (:mod:`vo.estimators.near_far`) where its gate says the
        calibration is inconsistent (near landmarks that only the joint fit, pulled by the far ones, rejects
        then stay tracks), else the joint fit's: with a consistent calibration the estimator is unchanged."""
        with timed(timings, "pnp"):
            cam = self.rig.cameras[0]
            T_c0_o = inv_T(T_o_c0)
            T_c0_o_split, inl_split = refine_on_near(T_c0_o, inl, near, rays, p_o,
                                                     undistort_px(self.tracker.pts, cam), cam.K, self.pnp_config)
            if T_c0_o_split is T_c0_o:                  # no split this frame (too few near or far landmarks)
                return T_o_c0, inl
            T_split, c_prev = inv_T(T_c0_o_split), self.T_o_c0[:3, 3]
            use = self._gate.use_split(float(np.linalg.norm(T_o_c0[:3, 3] - c_prev)),
                                       float(np.linalg.norm(T_split[:3, 3] - c_prev)))
        return (T_split, inl_split) if use else (T_o_c0, inl)
