"""``VinsConfig``: options of the seed-002 VINS (field names are the option / YAML keys).

Defaults are seed 002 Table 1 (F_c = 460, s = 0.02, M_s = 0.02, n = 11; its IMU noise n_a = 0.1, n_w = 0.01,
b_a = 0.001, b_w = 0.0001) and the VINS-Mono front-end defaults the paper builds on (150 features, 30 px
minimum distance, F-matrix RANSAC at 1 px, keyframe parallax 10 px at the virtual focal length).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from vo.errors import EstimatorError

ROBUST = ("none", "cauchy", "huber", "adaptive-huber")
IMU_NOISE = ("rig", "table1")
COVARIANCE = ("frame", "off")
INIT = ("vi", "truth")

# seed 002 Table 2/3 configurations (plus a fixed-k Huber for comparison). "VINS" is VINS-Mono [6], whose
# visual factors carry a Cauchy loss (scale 1 in whitened units); VINS-AC-ME replaces it by the adaptive Huber.
PRESETS = {
    "vins": dict(use_gf=False, use_track_count=False, robust="cauchy"),
    "vins-ac-gf": dict(use_gf=True, use_track_count=False, robust="cauchy"),
    "vins-ac": dict(use_gf=True, use_track_count=True, robust="cauchy"),
    "vins-ac-me": dict(use_gf=True, use_track_count=True, robust="adaptive-huber"),
    "vins-huber": dict(use_gf=False, use_track_count=False, robust="huber"),
}


@dataclass(frozen=True)
class VinsConfig:
    """Options (units in the names).

    Visual noise: ``pixel_sigma`` (1.5 px) at ``virtual_focal`` (F_c = 460 px), eq. 27; ``use_gf`` scales the
    square-root information by 1/g_f (eq. 22-25); ``use_track_count`` by N*s (eq. 26, ``s``); ``robust``:
    "none", "cauchy" (VINS-Mono's loss, scale ``robust_k``), "huber" (fixed k = ``robust_k``) or
    "adaptive-huber" (k_t = ``m_s`` * N, eq. 30); thresholds in whitened units.
    ``weight_min``/``weight_max`` bound the eq. 26 weight (a guard against degenerate g_f; 0 / inf = off).
    Window: ``window_size`` states (n = 11: 10 keyframes + newest), ``lm_iterations`` per frame.
    Front-end: ``max_features``, ``min_distance_px``, ``f_threshold_px``, ``min_parallax_px`` (at F_c),
    ``min_tracked`` (fewer tracked features than this -> keyframe). IMU: ``imu_noise`` "rig" (the rig's
    calibrated Kalibr densities, as a VINS-Mono user configures the IMU; Table 1's when the rig has none) or
    "table1" (seed 002's Xsens values ``acc_n``, ``gyr_n``, ``acc_w``, ``gyr_w``).
    Start-up: SfM + alignment is tried at every new keyframe once there are ``init_min_keyframes``, on at most
    ``init_keyframes`` (the oldest dropped after a failure; ``init=truth`` starts at ``init_keyframes``),
    ``init_min_parallax_px``,
    ``init_max_scale_std`` (largest accepted relative standard deviation of the aligned scale).
    ``init`` "vi" (monocular visual-inertial, VINS-Mono) or "truth" (window started from the true keyframe
    states of a simulated dataset: :mod:`vo.vins.truth_init`, for comparing back-ends where "vi" cannot start).
    Output: ``covariance`` "frame" (gtsam marginal of the newest state every frame, ``FrameResult.cov``) or "off".
    """

    use_gf: bool = False
    use_track_count: bool = False
    robust: str = "cauchy"
    robust_k: float = 1.0
    pixel_sigma: float = 1.5
    virtual_focal: float = 460.0
    s: float = 0.02
    m_s: float = 0.02
    weight_min: float = 0.0
    weight_max: float = math.inf
    window_size: int = 11
    lm_iterations: int = 6
    max_features: int = 150
    min_distance_px: int = 30
    f_threshold_px: float = 1.0
    min_parallax_px: float = 10.0
    min_tracked: int = 20
    imu_noise: str = "rig"
    acc_n: float = 0.1
    gyr_n: float = 0.01
    acc_w: float = 0.001
    gyr_w: float = 0.0001
    init_keyframes: int = 11
    init_min_keyframes: int = 11
    init_min_parallax_px: float = 30.0
    init_max_scale_std: float = 0.05
    covariance: str = "frame"
    init: str = "vi"

    def __post_init__(self):
        positive = ("robust_k", "pixel_sigma", "virtual_focal", "s", "m_s", "weight_max", "f_threshold_px",
                    "min_parallax_px", "acc_n", "gyr_n", "acc_w", "gyr_w", "init_min_parallax_px", "init_max_scale_std")
        for name in positive:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 or math.isnan(v):
                raise EstimatorError(f"vins option {name}: must be a positive number, got {v!r}")
        if not (isinstance(self.weight_min, (int, float)) and 0 <= self.weight_min < self.weight_max):
            raise EstimatorError(f"vins option weight_min: must be in [0, weight_max), got {self.weight_min!r}")
        ints = {"window_size": 3, "lm_iterations": 1, "max_features": 8, "min_distance_px": 1, "min_tracked": 0,
                "init_keyframes": 3, "init_min_keyframes": 3}
        for name, lo in ints.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise EstimatorError(f"vins option {name}: must be an integer >= {lo}, got {v!r}")
        if self.init_min_keyframes > self.init_keyframes:
            raise EstimatorError(f"vins option init_min_keyframes: must be <= init_keyframes ({self.init_keyframes}), "
                                 f"got {self.init_min_keyframes!r}")
        if self.init_keyframes > self.window_size:
            raise EstimatorError(f"vins option init_keyframes: must be <= window_size ({self.window_size}), "
                                 f"got {self.init_keyframes!r}")
        for name in ("use_gf", "use_track_count"):
            if not isinstance(getattr(self, name), bool):
                raise EstimatorError(f"vins option {name}: must be true or false, got {getattr(self, name)!r}")
        if self.robust not in ROBUST:
            raise EstimatorError(f"vins option robust: must be one of {', '.join(ROBUST)}, got {self.robust!r}")
        if self.init not in INIT:
            raise EstimatorError(f"vins option init: must be one of {', '.join(INIT)}, got {self.init!r}")
        if self.covariance not in COVARIANCE:
            raise EstimatorError(f"vins option covariance: must be one of {', '.join(COVARIANCE)}, "
                                 f"got {self.covariance!r}")
        if self.imu_noise not in IMU_NOISE:
            raise EstimatorError(f"vins option imu_noise: must be one of {', '.join(IMU_NOISE)}, "
                                 f"got {self.imu_noise!r}")

    @classmethod
    def from_options(cls, preset: str, options: dict) -> "VinsConfig":
        """``PRESETS[preset]`` updated by ``options``; unknown keys -> EstimatorError naming them."""
        names = {f.name for f in fields(cls)}
        bad = sorted(set(options) - names)
        if bad:
            raise EstimatorError(f"vins: unknown option(s) {', '.join(bad)}; valid: {', '.join(sorted(names))}")
        if preset not in PRESETS:
            raise EstimatorError(f"vins: unknown configuration {preset!r}; valid: {', '.join(PRESETS)}")
        return cls(**{**PRESETS[preset], **options})
