"""Configuration of the ``rop`` estimator: one frozen dataclass whose fields are the ``--opt`` / YAML keys.

Seed 000 fixes the method (four ROPs per epoch pair, two-step adjustment, chaining); every field here
is either a RANSAC / gating parameter the paper leaves open or one of our documented extensions
(docs/estimators.md). Invalid values raise one-line :class:`~vo.errors.EstimatorError` naming
``rop.<field>``, the value and what is valid.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from vo.errors import EstimatorError, VoError
from vo.frontend.klt import KltConfig
from vo.rop.bootstrap_cov import MIN_REPLICATES
from vo.rop.matching import KINDS as FRONTENDS
from vo.rop.relative import LOSSES, METHODS
from vo.rop.ropset import WEIGHTINGS
from vo.rop.tracks import KltFourView

COVS = ("propagated", "chain_bootstrap")      # vo.rop.uncertainty.make_uncertainty


@dataclass(frozen=True)
class RopConfig:
    """Options of :class:`vo.rop.estimator.RopEstimator` (defaults: the benchmarked configuration).

    ``frontend`` four-view KLT tracks (seed 003's, default) or descriptor matches of the four pairs;
    RANSAC of each essential matrix: ``ransac_threshold_px`` (Sampson gate, px), ``ransac_method``,
    ``ransac_max_iters``, ``ransac_prob``, ``seed``; ``min_matches`` four-view tracks (or pair matches)
    needed; a ROP needs ``max(min_rop_inliers, min_inlier_ratio * matches)`` inliers and must agree
    within ``max_rop_rotation_deg`` with the consensus; ``weights`` "inliers" (seed 000) | "sampson";
    ``min_parallax_px`` below it the epoch is rotation-only; a keyframe when the step reaches
    ``keyframe_baseline_ratio`` x the baseline or the tracks fall below ``keyframe_min_track_ratio`` of
    the keyframe's; ``constant_velocity`` coasting on failure (else the pose is held);
    ``klt_config`` (:class:`KltConfig` or a mapping of its fields), ``klt_refine`` "translation" |
    "affine"; ``rop_loss`` final ROP fit: "gate" (inliers at the RANSAC gate, least squares) |
    "tukey" | "cauchy" (robust, no step); ``cov`` "propagated" (first order) | "chain_bootstrap"
    (:mod:`vo.rop.chain_bootstrap`), ``bootstrap_replicates`` its replicate count."""

    frontend: str = "klt"
    ransac_threshold_px: float = 1.0
    ransac_method: str = "ransac"
    ransac_max_iters: int = 200
    ransac_prob: float = 0.999
    seed: int = 0
    min_matches: int = 30
    min_rop_inliers: int = 20
    min_inlier_ratio: float = 0.5
    max_rop_rotation_deg: float = 1.0
    weights: str = "inliers"
    min_parallax_px: float = 0.75
    keyframe_baseline_ratio: float = 2.0
    keyframe_min_track_ratio: float = 0.5
    constant_velocity: bool = True
    klt_config: KltConfig = field(default_factory=KltConfig)
    klt_refine: str = "translation"
    rop_loss: str = "gate"
    cov: str = "propagated"
    bootstrap_replicates: int = 40

    def __post_init__(self):
        for name, valid in (("frontend", FRONTENDS), ("ransac_method", tuple(METHODS)), ("weights", WEIGHTINGS),
                            ("klt_refine", KltFourView.REFINES), ("rop_loss", LOSSES), ("cov", COVS)):
            if getattr(self, name) not in valid:
                _bad(name, getattr(self, name), "valid: " + ", ".join(valid))
        for name, lo in (("ransac_max_iters", 1), ("seed", 0), ("min_matches", 8), ("min_rop_inliers", 5),
                         ("bootstrap_replicates", MIN_REPLICATES)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                _bad(name, v, f"must be an integer >= {lo}")
        for name, ok, what in (
                ("ransac_threshold_px", lambda v: v > 0, "> 0"), ("ransac_prob", lambda v: 0 < v < 1, "in (0, 1)"),
                ("min_inlier_ratio", lambda v: 0 <= v <= 1, "in [0, 1]"),
                ("max_rop_rotation_deg", lambda v: v > 0, "> 0"),
                ("min_parallax_px", lambda v: v >= 0, ">= 0"), ("keyframe_baseline_ratio", lambda v: v > 0, "> 0"),
                ("keyframe_min_track_ratio", lambda v: 0 <= v <= 1, "in [0, 1]")):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not ok(v):
                _bad(name, v, f"must be a finite number {what}")
        if not isinstance(self.constant_velocity, bool):
            _bad("constant_velocity", self.constant_velocity, "must be true or false")
        try:
            object.__setattr__(self, "klt_config", KltConfig.from_option(self.klt_config, "rop.klt_config"))
        except (VoError, TypeError) as e:
            raise EstimatorError(str(e) if str(e).startswith("rop.") else f"rop.klt_config: {e}") from None

    @classmethod
    def from_options(cls, options: dict) -> "RopConfig":
        """``--opt`` / YAML mapping of field names -> :class:`RopConfig` (unknown keys name the valid ones)."""
        names = [f.name for f in dataclasses.fields(cls)]
        bad = sorted(set(options) - set(names))
        if bad:
            raise EstimatorError(f"rop: unknown option(s) {bad}; valid: {', '.join(names)}")
        return cls(**options)


def _bad(name: str, value, what: str):
    raise EstimatorError(f"rop.{name}: {value!r}; {what}")
