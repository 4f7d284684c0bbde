"""The stereo PnP frame loop shared by ``klt-pnp`` (:mod:`vo.estimators.pnp`) and ``orb-pnp``
(:mod:`vo.estimators.orb_pnp`): (re)initialisation on a stereo keyframe, a PnP + RANSAC pose each frame, coasting on
failure. Too few tracked landmarks -> status ``few_features`` ("N tracked < M"), PnP failure -> ``lost``; the pose
is coasted (constant velocity, the median translation of the last measured steps, ``coast_velocity``, for
``max_coast_frames``, then held) and the next frame with a good stereo pair re-initialises a keyframe at the
current estimate -> ``reinit``. Never NaN.
"""
from __future__ import annotations

import time

import numpy as np

from rigs.geometry import inv_T, make_T, transform_points
from rigs.image import to_gray
from vo.errors import EstimatorError
from vo.estimators.base import MAX_COAST_FRAMES, Estimator, FrameResult
from vo.estimators.coast_velocity import StepHistory
from vo.estimators.pnp_core import PnpConfig, solve_pnp
from vo.estimators.stage_timing import timed
from vo.frontend.stereo import triangulate, undistort_px


class StereoPnpEstimator(Estimator):
    """Common frame loop: (re)initialisation, coasting on failure, timings. Subclasses implement
    ``_initialize(left, right, timings) -> (n_landmarks, message)`` and ``_step(left, right, timings)``.

    Hooks (constructor, for studies and validations; default none): ``pnp_observer(px (N,2), inliers (N,)
    bool)`` receives each PnP's raw left pixels and its inlier mask; ``pnp_select(px (N,2)) -> (N,) bool``
    keeps only the selected correspondences for the PnP (the others count as outliers), e.g. a study's
    true static/moving segmentation."""

    def __init__(self, rig, pnp_config: PnpConfig | None = None, pnp_observer=None, pnp_select=None, **options):
        super().__init__(rig, **options)
        self.pnp_observer, self.pnp_select = pnp_observer, pnp_select
        if not rig.is_stereo:
            raise EstimatorError(f"{self.name}: rig {rig.name!r} has one camera; a stereo rig is required")
        self.pnp_config = PnpConfig.from_option(pnp_config, f"{self.name}.pnp_config")
        self.T_o_c0 = np.eye(4)
        self._T_prev_curr = np.eye(4)      # last inter-frame motion T_{c(k-1)}_{c(k)}
        self._steps = StepHistory()        # the last measured ones, whose median translation coasting takes
        self._initialized = False
        self._need_init = True
        self._coast = 0

    def process(self, frame) -> FrameResult:
        t0 = time.perf_counter()
        timings = {"detect": 0.0, "track": 0.0, "stereo": 0.0, "pnp": 0.0}
        left, right = to_gray(frame.left), to_gray(frame.right)
        if self._need_init:
            res = self._try_init(frame.t_ns, left, right, timings)
        else:
            res = self._step(frame.t_ns, left, right, timings)
        timings["total"] = (time.perf_counter() - t0) * 1e3
        res.timings_ms = timings
        return res

    def _try_init(self, t_ns, left, right, timings) -> FrameResult:
        """Build a keyframe at the current pose: the first one defines ``o`` (its identity pose is the origin,
        class ok); a later one sits at the coasted pose (class coasting, or lost once the pose is held). Before
        the first keyframe the identity is a placeholder (class init)."""
        pose_class = self._coast_pose(self._coast_rotation(left, timings)) if self._initialized else "init"
        n_lm = self._initialize(left, right, timings)
        if n_lm < self.pnp_config.min_init_landmarks:
            return self._result(t_ns, "few_features", n_lm, 0,
                                f"{n_lm} stereo landmarks < {self.pnp_config.min_init_landmarks}: blank or "
                                f"textureless view?", pose_class)
        status = "reinit" if self._initialized else "init"
        self._initialized, self._need_init, self._coast = True, False, 0
        return self._result(t_ns, status, n_lm, n_lm, f"keyframe with {n_lm} landmarks",
                            pose_class if status == "reinit" else "ok")

    def _fail(self, t_ns, status, n_feat, n_inl, message, R_prev_curr=None) -> FrameResult:
        """Tracking failed: coast the pose (turned by ``R_prev_curr`` when measured), re-initialise next frame."""
        pose_class = self._coast_pose(R_prev_curr)
        self._need_init = True
        return self._result(t_ns, status, n_feat, n_inl, message, pose_class)

    def _coast_rotation(self, left, timings):
        """``R_prev_curr`` (3,3) measured without a pose fit for a frame about to be coasted, or None."""
        return None

    def _coast_pose(self, R_prev_curr=None) -> str:
        """Extrapolate the pose at constant velocity (rotation ``R_prev_curr`` when given; -> "coasting"), or hold
        it after :data:`MAX_COAST_FRAMES` failed frames (-> "lost")."""
        coast = self._coast < MAX_COAST_FRAMES
        if coast:
            R = self._T_prev_curr[:3, :3] if R_prev_curr is None else R_prev_curr
            self._T_prev_curr = make_T(R, self._steps.translation(self._T_prev_curr[:3, 3]))
            self.T_o_c0 = self.T_o_c0 @ self._T_prev_curr
        self._coast += 1
        return "coasting" if coast else "lost"

    def _accept_pose(self, T_o_c0_new) -> bool:
        """Update pose and velocity unless the step is implausibly large."""
        T_prev_curr = inv_T(self.T_o_c0) @ T_o_c0_new
        if np.linalg.norm(T_prev_curr[:3, 3]) > self.pnp_config.max_step_m:
            return False
        self._T_prev_curr, self.T_o_c0, self._coast = T_prev_curr, T_o_c0_new, 0
        self._steps.push(T_prev_curr)
        return True

    @property
    def predicted_T_o_c0(self) -> np.ndarray:
        """(4,4) the constant-velocity prediction of this frame's pose: the PnP's motion prior, and where
        ``klt-pnp`` predicts its tracks."""
        return self.T_o_c0 @ self._T_prev_curr

    def _pnp(self, p_o, px_raw, timings, use=None):
        px_raw = np.asarray(px_raw)
        keep = None if self.pnp_select is None else np.asarray(self.pnp_select(px_raw), bool)
        keep = use if keep is None else (keep if use is None else keep & use)   # use (N,) bool: may define the pose
        with timed(timings, "pnp"):
            cam = self.rig.cameras[0]
            if keep is None:
                T, inl = solve_pnp(p_o, undistort_px(px_raw, cam), cam.K, self.pnp_config,
                                   T_o_c0_prior=self.predicted_T_o_c0)
            else:
                T, inl_kept = solve_pnp(np.asarray(p_o)[keep], undistort_px(px_raw[keep], cam), cam.K,
                                        self.pnp_config, T_o_c0_prior=self.predicted_T_o_c0)
                inl = np.zeros(len(px_raw), bool)
                inl[keep] = inl_kept
        if self.pnp_observer is not None:
            self.pnp_observer(px_raw.copy(), np.asarray(inl, bool).copy())
        return T, inl

    def _triangulate_o(self, p_left, p_right) -> tuple:
        """Raw stereo pixel pairs -> ``(p_o (N,3), ok (N,))`` in the odometry frame at the current pose."""
        c = self.pnp_config
        p_c0, ok = triangulate(self.rig, p_left, p_right, c.max_depth, c.max_triangulation_px)
        return transform_points(self.T_o_c0, p_c0), ok

    def _result(self, t_ns, status, n_feat, n_inl, message="", pose_class="ok") -> FrameResult:
        return FrameResult(int(t_ns), self.T_o_c0.copy(), status, int(n_feat), int(n_inl), None, message,
                           pose_class=pose_class)
