"""``VinsEstimator``: seed 002's monocular VINS (left camera + IMU) behind the project's Estimator interface.

Output ``T_o_c0``: the left camera in the frame of the first left camera. Until the visual-inertial
initialisation succeeds every frame reports ``init`` with the identity pose; the pose of the first frame in
the estimator's gravity-aligned world is recovered from the first initialisation keyframe by inverting the
pre-integration (eq. 10-12) over the frames the initialisation did not use.
Per-frame diagnostics for plots and tables: ``self.diagnostics`` (a list of dicts: ``t_ns``, ``g_f``,
``counts`` = N per feature, ``px`` their raw pixels, ``frac_n_lt_10`` = the paper's outlier rule, ``n_landmarks``,
``status``, ``message``;
with a segmentation (``set_dataset``) also the true labels and the rule's confusion, :mod:`vo.vins.truth_segmentation`).
``FrameResult.cov``: the covariance of ``[rotvec, position]`` of ``T_o_c0`` every frame (:mod:`vo.vins.covariance`).
``vins-oracle`` keeps features off moving objects (true segmentation): its front-end drops those tracked onto
them and detects none there, so the feature budget goes to the static scene.
"""
from __future__ import annotations

import time

import cv2
import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X

from vo.errors import EstimatorError
from vo.estimators.base import Estimator, FrameResult
from vo.vins.vins_config import VinsConfig
from vo.vins.covariance import INIT_COV, output_covariance
from vo.vins.divergence import DivergenceCheck, Snapshot
from vo.vins.feature_tracker import KltFrontend, is_keyframe, mask_at
from vo.vins.imu import GRAVITY, ImuStream, imu_params, preintegrate
from vo.vins.vi_init import SFM_FAILED, initialize, usable_points, window_scale_change
from vo.vins.truth_segmentation import FeatureLabels, rule_confusion
from vo.vins.truth_init import Truth, truth_init
from vo.vins.window import Window


def drop_init_keyframe(keyframes: list, sfm_failed: bool) -> None:
    """Make room in ``keyframes`` (the start's keyframes, oldest first; changed in place) for the next one after a
    failed initialisation. When the SfM failed, the oldest keyframe goes (VINS-Mono's sliding window). When the
    SfM worked but the scale was not observable (or the window did not confirm it), the inner keyframe whose
    removal leaves the shortest merged interval goes instead, so the window grows in time and keeps the start of the motion: the scale is carried
    by changes of the acceleration, which a longer window sees more of (constant acceleration alone cannot
    separate scale and gravity)."""
    kf = keyframes
    if sfm_failed or len(kf) < 3:
        kf.pop(0)
        return
    gaps = [kf[k + 1].t_ns - kf[k - 1].t_ns for k in range(1, len(kf) - 1)]
    kf.pop(1 + int(np.argmin(gaps)))


class VinsEstimator(Estimator):
    """Seed 002's monocular VINS-Mono baseline: fixed visual information (1.5 px at F_c 460), Cauchy loss."""

    name = "vins"

    def __init__(self, rig, preset: str = "base", initializer=None, divergence=None, frontend=None, **options):
        """``preset``: one of :data:`vo.vins.vins_config.PRESETS` (seed 002's configurations), updated by ``options``;
        the estimator is named as registered, ``vins`` (``base``) or ``vins-<preset>``.
        ``initializer``: the visual-inertial start, called as :func:`vo.vins.vi_init.initialize` (default);
        ``divergence``: the failure test after each window optimisation, called as
        :class:`vo.vins.divergence.DivergenceCheck` (default: one with the ``fail_*`` options);
        ``frontend``: called once with the configured :class:`vo.vins.feature_tracker.KltFrontend`, returns the tracker
        to use (its ``track`` / ``undistort`` / ``size``; default: that front-end itself), e.g. a study's wrapper."""
        super().__init__(rig, preset=preset, **options)
        self.config = cfg = VinsConfig.from_options(preset, options)
        self.preset, self.remove_dynamic = preset, cfg.remove_dynamic
        self.name = "vins" if preset == "base" else f"vins-{preset}"
        self.initializer = initialize if initializer is None else initializer
        self.divergence = divergence if divergence is not None else DivergenceCheck(
            cfg.fail_max_acc_bias, cfg.fail_max_gyr_bias, cfg.fail_max_step_m, cfg.fail_max_dz_m,
            cfg.fail_max_velocity_jump_mps, cfg.fail_max_scale_jump)
        self.camera = rig.cameras[0]
        self.T_i_c = np.linalg.inv(rig.imu.T_b_i_array) @ self.camera.T_b_c_array
        self.params = imu_params(self.config, rig.imu)
        klt = KltFrontend(self.camera, self.config.max_features, self.config.min_distance_px,
                          self.config.f_threshold_px, self.config.klt_refine)
        self.frontend = klt if frontend is None else frontend(klt)
        self.stream = None
        self.first_frame = None
        self.reinitialising = False     # after a divergence, until the start succeeds again
        self.emitted = False            # a pose was produced (status ok / keyframe) at least once
        self.provisional_since = None   # t_ns of a provisional start the window has not confirmed yet
        self.diagnostics: list = []
        self._reset()
        self.T_o_w = None
        self.last_T_o_c = np.eye(4)
        self.labels = None
        self.truth = None

    def set_imu(self, imu) -> None:
        self.stream = ImuStream(imu)

    @classmethod
    def is_oracle(cls, options: dict) -> bool:
        """``vins-oracle`` (true segmentation) and ``init=truth`` (true start) read ground truth."""
        opts = dict(options)
        cfg = VinsConfig.from_options(opts.pop("preset", "base"), opts)
        return cfg.remove_dynamic or cfg.init == "truth"

    def set_dataset(self, dataset) -> None:
        """Read the true segmentation when the dataset has it (diagnostics; required by ``vins-oracle``); the
        runner passes the whole dataset only to an oracle (:meth:`is_oracle`), a sensor-only one otherwise."""
        self.labels = FeatureLabels.of(dataset)
        if self.config.init == "truth":
            self.truth = Truth(dataset)
        if self.remove_dynamic and self.labels is None:
            raise EstimatorError(f"{self.name}: the dataset has no segmentation (cam0/segmentation); "
                                 f"generate it with --segmentation")

    def _reset(self) -> None:
        """Forget the window and the initialisation keyframes (VINS-Mono's ``clearState``): start again."""
        self.window = None
        self.init_frames: list = []
        self.provisional_since = None
        self.last_attempt = None        # (t_ns, message) of the last failed start attempt

    def _diverged(self, frame, feats, message: str) -> FrameResult:
        """The window failed: reset and start a new initialisation from this frame on. Every frame until it
        succeeds is ``reinit`` (not ``init``: a pose was produced before) with the last emitted pose held."""
        self._reset()
        self.reinitialising = self.emitted
        return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(), message=message)

    # ------------------------------------------------------------------ per frame
    def process(self, frame) -> FrameResult:
        if self.stream is None:
            raise EstimatorError(f"{self.name}: the dataset has no IMU (imu0/data.csv missing); VINS needs imu0")
        t0 = time.perf_counter()
        moving = self.labels.mask(frame.index) if self.labels is not None else None
        feats = self.frontend.track(frame.left, frame.t_ns, moving if self.remove_dynamic else None)
        dynamic = mask_at(moving, feats.px) if moving is not None else None
        t1 = time.perf_counter()
        if self.first_frame is None and feats.t_ns >= self.stream.t[0]:
            self.first_frame = feats        # images older than the first IMU sample are dropped, as in VINS-Mono
        if self.first_frame is None:
            res = FrameResult(frame.t_ns, self.last_T_o_c.copy(), "init", message="before the first IMU sample")
        elif feats.t_ns > self.stream.t[-1]:        # images after the last IMU sample: no motion to integrate
            status = self._init_status() if self.window is None else "lost"
            res = FrameResult(frame.t_ns, self.last_T_o_c.copy(), status, message="after the last IMU sample")
        elif self.window is None:
            res = self._process_init(frame, feats)
        else:
            res = self._process_window(frame, feats)
        t2 = time.perf_counter()
        self._set_covariance(res)
        t3 = time.perf_counter()
        res.n_features = len(feats.ids)
        res.timings_ms = {"track": (t1 - t0) * 1e3, "optimize": (t2 - t1) * 1e3, "covariance": (t3 - t2) * 1e3,
                          "total": (t3 - t0) * 1e3}
        self._diagnose(feats, res, dynamic)
        if res.status != "init":
            self.last_T_o_c = res.T_o_c0
        self.emitted = self.emitted or res.status in ("ok", "keyframe")
        if res.status == "reinit":          # the last pose held while the start is redone: no pose produced
            res.pose_class = "lost"
        return res

    def _set_covariance(self, res) -> None:
        """``res.cov``: marginal of the newest state (:meth:`Window.pose_covariance`) mapped to ``T_o_c0``
        (:mod:`vo.vins.covariance`);
        :data:`INIT_COV` (motion unknown) while initialising or after a reset."""
        if res.status in ("init", "reinit") or self.window is None or self.config.covariance == "off":
            res.cov = None if self.config.covariance == "off" else INIT_COV.copy()
            return
        w, st = self.window, self.window.states[-1]
        try:
            P_x = w.pose_covariance(st)
        except (RuntimeError, np.linalg.LinAlgError) as e:     # singular information: say so, keep the pose
            res.cov, res.message = INIT_COV.copy(), f"no covariance: {e}"
            return
        res.cov = output_covariance(P_x, self.T_o_w, w.values.atPose3(X(st.k)).matrix(), self.T_i_c)

    def _is_keyframe(self, feats, last_kf, max_interval_s: float = float("inf")) -> bool:
        cfg = self.config
        return is_keyframe(feats, last_kf, cfg.min_parallax_px, cfg.min_tracked, cfg.virtual_focal, max_interval_s)

    def _init_status(self) -> str:
        return "reinit" if self.reinitialising else "init"

    def _process_init(self, frame, feats) -> FrameResult:
        if not self.stream.covers(self.first_frame.t_ns, feats.t_ns):
            return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(),
                               message="no IMU at this frame time")
        new_kf = self._is_keyframe(feats, self.init_frames[-1] if self.init_frames else None)
        if new_kf:
            self.init_frames.append(feats)
        cfg = self.config
        need = cfg.init_keyframes if cfg.init == "truth" else cfg.init_min_keyframes
        msg = f"collecting keyframes {len(self.init_frames)}/{need}"
        if cfg.init == "truth" and len(self.init_frames) >= need:
            if self.truth is None:
                raise EstimatorError(f"{self.name}: init=truth needs the dataset's ground truth (run it on a "
                                     f"dataset through the runner)")
            return self._initialised(frame, truth_init(self.truth, self.init_frames))
        if cfg.init == "vi" and new_kf and len(self.init_frames) >= need:
            last = self.last_attempt
            if self.reinitialising and last and (feats.t_ns - last[0]) * 1e-9 < cfg.reinit_attempt_interval_s:
                msg = f"{last[1]} (next attempt {cfg.reinit_attempt_interval_s:g} s after it)"
            else:
                result, msg = self.initializer(self.stream, self.params, self.init_frames, self.T_i_c, cfg)
                if result is not None:
                    return self._initialised(frame, result)
                self.last_attempt = last = (feats.t_ns, msg)
            if len(self.init_frames) >= cfg.init_keyframes:
                drop_init_keyframe(self.init_frames, last[1] == SFM_FAILED)
        return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(), message=msg)

    def _initialised(self, frame, result) -> FrameResult:
        self._start_window(result)
        w, cfg = self.window, self.config
        change = window_scale_change(result, np.array([w.T_w_c(st) for st in w.states]))
        if not result.provisional and abs(change) > cfg.init_window_check:
            self.window = None              # the window does not confirm the alignment: a longer one retries
            if len(self.init_frames) >= cfg.init_keyframes:
                drop_init_keyframe(self.init_frames, False)
            return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(),
                               message=f"scale not confirmed: the window moved it {100 * change:+.1f} %")
        if result.provisional:
            self.provisional_since = frame.t_ns
            return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(),
                               message=f"provisional start (alignment scale std {100 * result.scale_rel_std:.1f} %)")
        self.reinitialising = False
        T_w_c = self.window.T_w_c(self.window.states[-1])
        return FrameResult(frame.t_ns, self.T_o_w @ T_w_c, "keyframe", message="initialised")

    def _start_window(self, r) -> None:
        """Gravity-align the SfM frame v, scale it, fill the window with the initialisation keyframes."""
        R_w_v = _rotation_to_down(r.g_v)
        cfg = self.config
        self.window = w = Window(cfg, self.camera, self.T_i_c, self.stream, self.params)
        T_c_i = np.linalg.inv(self.T_i_c)
        bias = gtsam.imuBias.ConstantBias(np.zeros(3), r.bg)
        for k, fr in enumerate(self.init_frames):
            T_w_c = np.eye(4)
            T_w_c[:3, :3], T_w_c[:3, 3] = R_w_v @ r.R_v_c[k], R_w_v @ (r.scale * r.p_v_c[k])
            w.add_state(fr.t_ns, fr, True, T_w_c @ T_c_i, R_w_v @ r.v_v[k], bias)
        for i, p in usable_points(r, self.init_frames).items():
            w.add_landmark(i, R_w_v @ (r.scale * np.asarray(p)))
        for st in w.states:
            w.set_geometry(st)
        first = w.states[0]
        w.priors.append(gtsam.PriorFactorPose3(X(first.k), w.values.atPose3(X(first.k)),
                                               gtsam.noiseModel.Diagonal.Sigmas(np.array([1e-3] * 3 + [1e-3] * 3))))
        w.priors.append(gtsam.PriorFactorConstantBias(B(first.k), bias, gtsam.noiseModel.Diagonal.Sigmas(
            np.array([0.1] * 3 + [0.01] * 3))))
        w.optimize()
        if self.T_o_w is None and self.truth is not None:
            self.T_o_w = np.linalg.inv(self.truth.T_w_c[self.first_frame.t_ns])
        elif self.T_o_w is None or not self.emitted:
            self.T_o_w = np.linalg.inv(self._first_camera_pose())
        else:              # re-initialisation: the first new keyframe continues from the last emitted pose
            self.T_o_w = self.last_T_o_c @ np.linalg.inv(w.T_w_c(w.states[0]))

    def _first_camera_pose(self) -> np.ndarray:
        """T_w_c of the dataset's first frame: invert eq. 10-12 from the first window state back to it."""
        w, st = self.window, self.window.states[0]
        T_w_i = w.values.atPose3(X(st.k)).matrix()
        if st.t_ns == self.first_frame.t_ns:
            return T_w_i @ self.T_i_c
        pim = preintegrate(self.stream, self.params, self.first_frame.t_ns, st.t_ns, w.values.atConstantBias(B(st.k)))
        dt, g = pim.deltaTij(), np.array([0.0, 0.0, -GRAVITY])
        R0 = T_w_i[:3, :3] @ pim.deltaRij().matrix().T
        v0 = w.values.atVector(V(st.k)) - g * dt - R0 @ pim.deltaVij()
        T0 = np.eye(4)
        T0[:3, :3] = R0
        T0[:3, 3] = T_w_i[:3, 3] - v0 * dt - 0.5 * g * dt * dt - R0 @ pim.deltaPij()
        return T0 @ self.T_i_c

    def _process_window(self, frame, feats) -> FrameResult:
        w = self.window
        last_kf = next(st for st in reversed(w.states) if st.is_kf)
        is_kf = self._is_keyframe(feats, last_kf.feats, self.config.max_keyframe_interval_s)
        before = self._snapshot()
        try:
            new = w.add_state(feats.t_ns, feats, is_kf)
            v_pred = w.values.atVector(V(new.k))
            if not w.states[-2].is_kf:
                w.drop_second_newest()
            elif len(w.states) > self.config.window_size:
                w.marginalize_oldest()
            self._triangulate_new()
            w.optimize()
        except RuntimeError as e:                      # gtsam: indeterminant system, cheirality, ...
            return self._diverged(frame, feats, f"optimizer failed: {e}")
        T = self.T_o_w @ w.T_w_c(w.states[-1])
        if not np.all(np.isfinite(T)):
            return self._diverged(frame, feats, "non-finite estimate")
        why = self.divergence(before, v_pred, self._snapshot(), new.k)
        if why is not None:
            return self._diverged(frame, feats, why)
        if self.provisional_since is not None:
            return self._confirm(frame, T, is_kf)
        return FrameResult(frame.t_ns, T, "keyframe" if is_kf else "ok", n_inliers=len(w.lm))

    def speed_rel_std(self) -> float:
        """Relative standard deviation of the newest state's speed (:meth:`Window.velocity_covariance` along
        the velocity): the window's scale uncertainty once the vehicle moves (inf below 1 m/s)."""
        w = self.window
        st = w.states[-1]
        v = w.values.atVector(V(st.k))
        speed = float(np.linalg.norm(v))
        if speed < 1.0:
            return float("inf")
        u = v / speed
        try:
            return float(np.sqrt(max(u @ w.velocity_covariance(st) @ u, 0.0)) / speed)
        except (RuntimeError, np.linalg.LinAlgError):
            return float("inf")

    def _confirm(self, frame, T, is_kf) -> FrameResult:
        """Provisional start: emit the first pose once the window knows its speed (hence its scale) to
        ``init_max_scale_std``; drop the start after ``init_confirm_s`` without it."""
        cfg = self.config
        rel = self.speed_rel_std()
        if rel <= cfg.init_max_scale_std:
            self.provisional_since = None
            self.reinitialising = False
            return FrameResult(frame.t_ns, T, "keyframe" if is_kf else "ok", n_inliers=len(self.window.lm),
                               message="initialised")
        if (frame.t_ns - self.provisional_since) * 1e-9 > cfg.init_confirm_s:
            self._reset()
            return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(),
                               message=f"provisional start not confirmed in {cfg.init_confirm_s:g} s: start again")
        return FrameResult(frame.t_ns, self.last_T_o_c.copy(), self._init_status(),
                           message=f"provisional start: speed std {100 * rel:.1f} % > {100 * cfg.init_max_scale_std:g} %")

    def _snapshot(self) -> Snapshot:
        """The window's state positions and its newest velocity and biases (:mod:`vo.vins.divergence`)."""
        w = self.window
        b = w.values.atConstantBias(B(w.states[-1].k))
        return Snapshot({st.k: w.values.atPose3(X(st.k)).translation() for st in w.states},
                        w.values.atVector(V(w.states[-1].k)), b.accelerometer(), b.gyroscope())

    def _triangulate_new(self) -> None:
        """Landmarks for tracks seen in >= 2 window states, from the first and the newest observation.
        Point3: only with >= ``min_triangulation_deg`` of ray parallax and a point in front of both cameras.
        Inverse depth: every such track (VINS-Mono), at ``INIT_DEPTH_M`` where the triangulation fails."""
        w = self.window
        newest = w.states[-1]
        first_obs = {}
        for st in w.states[:-1]:
            for i, xy in zip(st.feats.ids, st.feats.xy):
                first_obs.setdefault(int(i), (st, xy))
        T_b = np.linalg.inv(w.T_w_c(newest))
        max_cos = np.cos(np.radians(self.config.min_triangulation_deg))
        for i, xy in zip(newest.feats.ids, newest.feats.xy):
            i = int(i)
            if i in w.lm or i not in first_obs:
                continue
            st, xa = first_obs[i]
            p = _two_view_point(np.linalg.inv(w.T_w_c(st)), T_b, xa, xy, 1.0 if w.inv_depth else max_cos)
            if p is not None or w.inv_depth:
                w.add_landmark(i, p)

    def _diagnose(self, feats, res, dynamic=None) -> None:
        """Per-frame record; with a segmentation also the true dynamic labels and the N < 10 rule's confusion
        (:func:`vo.vins.truth_segmentation.rule_confusion`)."""
        g_f = self.window.states[-1].g_f if self.window is not None and self.window.states else float("nan")
        d = {"t_ns": int(feats.t_ns), "g_f": float(g_f), "counts": feats.count.copy(), "px": feats.px.copy(),
             "frac_n_lt_10": float(np.mean(feats.count < 10)) if len(feats.count) else 0.0,
             "n_landmarks": len(self.window.lm) if self.window is not None else 0,
             "status": res.status, "message": res.message}
        if dynamic is not None:
            d["dynamic"] = np.asarray(dynamic, bool)
            d.update(rule_confusion(dynamic, feats.count))
        self.diagnostics.append(d)


def _two_view_point(T_a: np.ndarray, T_b: np.ndarray, xa: np.ndarray, xb: np.ndarray, max_cos: float):
    """World point (3,) of normalized observations ``xa``/``xb`` in cameras ``T_a``/``T_b`` (T_c_w, 4x4), or None
    when the rays' parallax angle has a cosine above ``max_cos``, the solution is at infinity, or it is not
    0.1-1000 m in front of both cameras."""
    ra = T_a[:3, :3].T @ np.append(xa, 1.0)
    rb = T_b[:3, :3].T @ np.append(xb, 1.0)
    if max_cos < 1 and ra @ rb / np.linalg.norm(ra) / np.linalg.norm(rb) > max_cos:
        return None
    P = cv2.triangulatePoints(T_a[:3], T_b[:3], xa.reshape(2, 1), xb.reshape(2, 1)).ravel()
    if abs(P[3]) < 1e-12:
        return None
    p = P[:3] / P[3]
    za, zb = (T_a @ np.append(p, 1))[2], (T_b @ np.append(p, 1))[2]
    return p if 0.1 < za < 1e3 and 0.1 < zb < 1e3 else None


def _rotation_to_down(g_v: np.ndarray) -> np.ndarray:
    """R_w_v with R_w_v g_v = [0, 0, -|g|] (smallest rotation; yaw is unobservable)."""
    a = np.asarray(g_v, float) / np.linalg.norm(g_v)
    b = np.array([0.0, 0.0, -1.0])
    v, c = np.cross(a, b), float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return gtsam.Rot3.Expmap(v / np.linalg.norm(v) * np.arctan2(np.linalg.norm(v), c)).matrix()

