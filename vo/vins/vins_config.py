"""``VinsConfig``: options of the seed-002 VINS (field names are the option / YAML keys).

Defaults are seed 002 Table 1 (F_c = 460, s = 0.02, M_s = 0.02, n = 11; its IMU noise n_a = 0.1, n_w = 0.01,
b_a = 0.001, b_w = 0.0001) and the VINS-Mono front-end defaults the paper builds on (150 features, 30 px
minimum distance, F-matrix RANSAC at 1 px, keyframe parallax 10 px at the virtual focal length).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real
from typing import Literal

from rigs.typed_config import check_fields, from_mapping, knob
from vo.errors import EstimatorError
from vo.estimators.experimental import resolve_experimental

ROBUST = ("none", "cauchy", "huber", "adaptive-huber")
IMU_NOISE = ("rig", "table1")
COVARIANCE = ("frame", "off")
INIT = ("vi", "truth")
N_COUNT = ("track", "window")
KLT_REFINE = ("none", "affine")
LANDMARK = ("point3", "inverse-depth")

# seed 002 Table 2/3 configurations (plus a fixed-k Huber for comparison and the true-segmentation oracle): the
# ``preset`` option of ``vins``, each also registered as ``vins-<preset>`` (vo.estimators.registry). "VINS"
# (``base``) is VINS-Mono [6], whose visual factors carry a Cauchy loss (scale 1 in whitened units); VINS-AC-ME
# replaces it by the adaptive Huber.
PRESETS = {
    "base": dict(use_gf=False, use_track_count=False, robust="cauchy"),
    "ac-gf": dict(use_gf=True, use_track_count=False, robust="cauchy"),
    "ac": dict(use_gf=True, use_track_count=True, robust="cauchy"),
    "ac-me": dict(use_gf=True, use_track_count=True, robust="adaptive-huber"),
    "huber": dict(use_gf=False, use_track_count=False, robust="huber"),
    "oracle": dict(use_gf=False, use_track_count=False, robust="cauchy", remove_dynamic=True),
}

# measured, non-default alternatives, given as ``experimental.<field>`` (vo.estimators.experimental); the
# decision and the study behind each: docs/estimators.md, "Experimental options"
EXPERIMENTAL = frozenset({"n_count", "weight_min", "weight_max", "landmark", "shift_depth", "hold_gauge",
                          "init_min_excitation", "init_provisional_scale_std", "init_confirm_s"})


def _positive_or_inf(value):
    """``weight_max`` is the one field where ``inf`` (no upper bound) is valid, so it is annotated
    :class:`numbers.Real` rather than ``float`` (whose check rejects inf) and checked here."""
    if isinstance(value, bool) or not isinstance(value, Real) or not value > 0:
        raise EstimatorError(f"vins.weight_max: must be a positive number or .inf, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class VinsConfig:
    """Options (units in the names).

    Visual noise: ``pixel_sigma`` (1.5 px) at ``virtual_focal`` (F_c = 460 px), eq. 27; ``use_gf`` scales the
    square-root information by 1/g_f (eq. 22-25); ``use_track_count`` by N*s (eq. 26, ``s``); ``robust``:
    "none", "cauchy" (VINS-Mono's loss, scale ``robust_k``), "huber" (fixed k = ``robust_k``) or
    "adaptive-huber" (k_t = ``m_s`` * N, eq. 30); thresholds in whitened units. ``n_count``: what N is,
    "track" (times tracked since the first detection, the front-end's count, uncapped: the reading of §4.1)
    or "window" (the number of window states observing the feature, VINS-Mono's ``used_num``, <= n).
    ``weight_min``/``weight_max`` bound the eq. 26 weight (a guard against degenerate g_f; 0 / inf = off).
    Window: ``window_size`` states (n = 11: 10 keyframes + newest), ``lm_iterations`` per frame; ``landmark``
    "point3" (world points, gtsam's built-in image-plane reprojection; new landmarks need
    ``min_triangulation_deg`` of ray parallax) or "inverse-depth" (eq. 14-19: inverse depth in the anchor
    frame, unit-sphere residual; every feature seen twice enters, as in VINS-Mono), :mod:`vo.vins.window`;
    ``shift_depth`` (point3): a marginalized landmark whose track goes on stays at its estimate as a new
    landmark at once, instead of waiting for re-triangulation (inverse depth always does, as VINS-Mono);
    ``hold_gauge``: after each optimization the window is moved back so that its oldest state keeps its position
    and yaw (VINS-Mono's ``double2vector``; position and yaw are unobservable).
    Front-end: ``max_features``, ``min_distance_px``, ``f_threshold_px``, ``min_parallax_px`` (at F_c),
    ``min_tracked`` (fewer tracked features than this -> keyframe), ``max_keyframe_interval_s`` (after the
    start, a frame this long after the window's newest keyframe is a keyframe: a deviation from seed 002 /
    VINS-Mono, whose parallax and count tests take no keyframe while the vehicle stands, so that one IMU factor
    spans the whole stop; measured on urban-dynamic seed 4, docs/vins.md), ``klt_refine`` "affine" (default, a deviation:
    each track refined against its first image, :mod:`vo.vins.feature_tracker`; translation-only KLT drifts on
    the perspective ground and biased the start's scale by 6-19 % in traffic, docs/vins.md) or "none"
    (VINS-Mono's KLT). IMU: ``imu_noise`` "rig" (the rig's
    calibrated Kalibr densities, as a VINS-Mono user configures the IMU; Table 1's when the rig has none) or
    "table1" (seed 002 Table 1's estimator configuration ``acc_n``, ``gyr_n``, ``acc_w``, ``gyr_w``, not the
    sensor's noise: :mod:`rigs.imu_models`).
    Start-up: SfM + alignment is tried at every new keyframe once there are ``init_min_keyframes``, on at most
    ``init_keyframes`` (after a failure the oldest is dropped if the SfM failed, else the inner keyframe of
    the shortest merged interval; a start whose scale the window's first optimisation moves by more than
    ``init_window_check`` (relative; 0.05, the target) is refused; ``init=truth`` starts at ``init_keyframes``), ``init_min_parallax_px``,
    ``init_max_scale_std`` (the target: largest accepted relative error bound of the aligned scale, and largest
    relative difference between the forward and reverse alignment regressions), ``init_scale_sigmas`` (the
    bound is this many relative standard deviations: 2 accepts a window whose scale is within the target at
    about 95 % confidence; 1 accepted a third of the starts beyond it, docs/vins.md), ``init_min_excitation``
    (m/s^2: the standard deviation over the window's keyframe intervals of the mean specific force, below which
    the window is not tried, :func:`vo.vins.vi_init.imu_excitation`; 0 = off, as in VINS-Mono, which logs its
    0.25 test without acting on it: the scale's standard deviation already says whether the motion observes
    it, and the campus cart's start from rest, 0.16-0.20 m/s^2, observes it to 1.3 %),
    ``reinit_attempt_interval_s``: after a divergence, a start attempt at a new keyframe only this long after
    the last failed one (0 = at every keyframe, as the first start and VINS-Mono; beyond seed 002: at speed
    every frame is a keyframe and each attempt costs 0.2-0.7 s of CPU, docs/vins.md);
    ``init_provisional_scale_std``: an alignment whose scale is known only to this (relative standard
    deviation) starts the window provisionally: no pose is emitted (status ``init``) until the window's own
    speed is known to ``init_max_scale_std``, or it is dropped after ``init_confirm_s`` seconds. Off by
    default (equal to ``init_max_scale_std``): the window's speed covariance is overconfident (measured with
    0.15 on urban seeds 0: the window confirmed a scale 11-16 % off as known to 5 %, docs/vins.md).
    Divergence (after initialisation, :class:`vo.vins.divergence.DivergenceCheck`): ``fail_max_acc_bias``,
    ``fail_max_gyr_bias``, ``fail_max_step_m``, ``fail_max_dz_m`` (VINS-Mono's ``failureDetection``),
    ``fail_max_velocity_jump_mps`` (newest velocity against its IMU prediction), ``fail_max_scale_jump``
    (relative change of the window's path length in one frame); the estimator then reinitialises.
    ``init`` "vi" (monocular visual-inertial, VINS-Mono) or "truth" (window started from the true keyframe
    states of a simulated dataset: :mod:`vo.vins.truth_init`, for comparing back-ends where "vi" cannot start).
    Output: ``covariance`` "frame" (gtsam marginal of the newest state every frame, ``FrameResult.cov``) or "off".
    ``remove_dynamic`` (preset ``oracle``): the front-end keeps no features on moving objects (true segmentation).
    Experimental (:data:`EXPERIMENTAL`, given as ``experimental.<field>``): ``n_count``, ``weight_min``,
    ``weight_max``, ``landmark``, ``shift_depth``, ``hold_gauge``, ``init_min_excitation``,
    ``init_provisional_scale_std``, ``init_confirm_s``.
    """

    use_gf: bool = False
    use_track_count: bool = False
    n_count: Literal[N_COUNT] = "track"
    robust: Literal[ROBUST] = "cauchy"
    robust_k: float = knob(1.0, gt=0)
    pixel_sigma: float = knob(1.5, gt=0)
    virtual_focal: float = knob(460.0, gt=0)
    s: float = knob(0.02, gt=0)
    m_s: float = knob(0.02, gt=0)
    weight_min: float = knob(0.0, ge=0)
    weight_max: Real = knob(math.inf, gt=0, parse=_positive_or_inf)
    window_size: int = knob(11, ge=3)
    lm_iterations: int = knob(6, ge=1)
    landmark: Literal[LANDMARK] = "point3"
    min_triangulation_deg: float = knob(1.0, ge=0, lt=90)
    shift_depth: bool = False
    hold_gauge: bool = False
    max_features: int = knob(150, ge=8)
    min_distance_px: int = knob(30, ge=1)
    f_threshold_px: float = knob(1.0, gt=0)
    min_parallax_px: float = knob(10.0, gt=0)
    min_tracked: int = knob(20, ge=0)
    max_keyframe_interval_s: float = knob(1.0, gt=0)
    klt_refine: Literal[KLT_REFINE] = "affine"
    imu_noise: Literal[IMU_NOISE] = "rig"
    acc_n: float = knob(0.1, gt=0)
    gyr_n: float = knob(0.01, gt=0)
    acc_w: float = knob(0.001, gt=0)
    gyr_w: float = knob(0.0001, gt=0)
    init_keyframes: int = knob(11, ge=3)
    init_min_keyframes: int = knob(11, ge=3)
    init_min_parallax_px: float = knob(30.0, gt=0)
    init_max_scale_std: float = knob(0.05, gt=0)
    init_scale_sigmas: float = knob(2.0, gt=0)
    init_window_check: float = knob(0.05, gt=0)
    init_min_excitation: float = knob(0.0, ge=0)
    init_provisional_scale_std: float = knob(0.05, gt=0)
    init_confirm_s: float = knob(10.0, gt=0)
    reinit_attempt_interval_s: float = knob(0.5, ge=0)
    fail_max_acc_bias: float = knob(2.5, gt=0)
    fail_max_gyr_bias: float = knob(1.0, gt=0)
    fail_max_step_m: float = knob(5.0, gt=0)
    fail_max_dz_m: float = knob(1.0, gt=0)
    fail_max_velocity_jump_mps: float = knob(2.0, gt=0)
    fail_max_scale_jump: float = knob(0.25, gt=0)
    covariance: Literal[COVARIANCE] = "frame"
    init: Literal[INIT] = "vi"
    remove_dynamic: bool = False

    def __post_init__(self):
        check_fields(self, EstimatorError, "vins.")
        object.__setattr__(self, "weight_max", _positive_or_inf(self.weight_max))
        if not self.weight_min < self.weight_max:
            raise EstimatorError(f"vins.weight_min: must be below weight_max ({self.weight_max!r}), "
                                 f"got {self.weight_min!r}")
        if self.init_min_keyframes > self.init_keyframes:
            raise EstimatorError(f"vins.init_min_keyframes: must be <= init_keyframes ({self.init_keyframes}), "
                                 f"got {self.init_min_keyframes!r}")
        if self.init_provisional_scale_std < self.init_max_scale_std:
            raise EstimatorError(f"vins.init_provisional_scale_std: must be >= init_max_scale_std "
                                 f"({self.init_max_scale_std}), got {self.init_provisional_scale_std!r}")
        if self.init_keyframes > self.window_size:
            raise EstimatorError(f"vins.init_keyframes: must be <= window_size ({self.window_size}), "
                                 f"got {self.init_keyframes!r}")

    @classmethod
    def from_options(cls, preset: str, options: dict) -> "VinsConfig":
        """``PRESETS[preset]`` updated by ``options``; unknown keys -> EstimatorError naming the valid ones. The
        fields in :data:`EXPERIMENTAL` are given as ``experimental.<field>``."""
        if preset not in PRESETS:
            raise EstimatorError(f"vins.preset: unknown {preset!r}; valid: {', '.join(PRESETS)}")
        options = resolve_experimental(options, EXPERIMENTAL, "vins")
        return from_mapping(cls, {**PRESETS[preset], **options}, EstimatorError, "vins")
