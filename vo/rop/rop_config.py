"""Configuration of the ``rop`` estimator: one frozen dataclass whose fields are the ``--opt`` / YAML keys.

Seed 000 fixes the method (four ROPs per epoch pair, two-step adjustment, chaining); every field here
is either a RANSAC / gating parameter the paper leaves open or one of our documented extensions
(docs/estimators.md). Invalid values raise one-line :class:`~vo.errors.EstimatorError` naming
``rop.<field>``, the value and what is valid (:mod:`rigs.typed_config`: choices are ``Literal`` of
the modules' own tuples, ranges are :func:`~rigs.typed_config.knob` bounds).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from rigs.typed_config import check_fields, from_mapping, knob
from vo.errors import EstimatorError, VoError
from vo.estimators.experimental import resolve_experimental
from vo.frontend.klt import KltConfig
from vo.rop.bootstrap_cov import MIN_REPLICATES
from vo.rop.matching import KINDS as FRONTENDS
from vo.rop.relative import LOSSES
from vo.rop.ropset import WEIGHTINGS
from vo.rop.tracks import KltFourView

COVS = ("propagated", "chain_bootstrap")      # vo.rop.cov_models.make_uncertainty
MOVING = ("prior", "none")                    # vo.rop.moving
MOVING_PRIORS = ("pnp", "velocity")           # vo.rop.estimator: prediction that selects the motion
ROTATION_TESTS = ("chi2", "degrees")          # vo.rop.rotation_test | vo.rop.weak_frame.rotation_miss
ROTATION_ACTIONS = ("direction", "rotation", "pose")   # vo.rop.rotation_test.readjusted_step | PnP pose
# measured, non-default alternatives, given as ``experimental.<field>`` (vo.estimators.experimental); the
# decision and the study behind each: docs/estimators.md, "Experimental options"
EXPERIMENTAL = frozenset({"weights", "klt_refine", "rop_loss", "moving_prior"})


def _klt_config(value) -> KltConfig:
    """``klt_config`` given as ``None`` (the defaults) or a mapping of :class:`KltConfig` fields."""
    try:
        return KltConfig.from_option(value, "rop.klt_config")
    except (VoError, TypeError) as e:
        raise EstimatorError(str(e) if str(e).startswith("rop.") else f"rop.klt_config: {e}") from None


@dataclass(frozen=True)
class RopConfig:
    """Options of :class:`vo.rop.estimator.RopEstimator` (defaults: the benchmarked configuration).

    ``frontend`` four-view KLT tracks (seed 003's, default) or descriptor matches of the four pairs;
    RANSAC of each essential matrix (OpenCV's RANSAC): ``ransac_threshold_px`` (Sampson gate, px),
    ``ransac_max_iters``, ``ransac_prob``, ``seed``; ``min_matches`` four-view tracks (or pair matches)
    needed; a ROP needs ``max(min_rop_inliers, min_inlier_ratio * matches)`` inliers and must agree
    within ``max_rop_rotation_deg`` with the consensus; ``weights`` "inliers" (seed 000) | "sampson";
    ``min_parallax_px`` below it the epoch is rotation-only; a keyframe when the step reaches
    ``keyframe_baseline_ratio`` x the baseline or the tracks fall below ``keyframe_min_track_ratio`` of
    the keyframe's;
    ``klt_config`` (:class:`KltConfig` or a mapping of its fields), ``klt_refine`` "translation" |
    "affine"; ``zncc_texture_snr`` the ZNCC check of the LK matches (``klt_config.min_zncc``) applies only to
    windows whose texture std is below this many times the image noise (0: to every window;
    :mod:`vo.frontend.patch_check`, docs/estimators.md "What the ZNCC check drops on whole campus routes");
    ``rop_loss`` final ROP fit: "gate" (inliers at the RANSAC gate, least squares) | "tukey" | "cauchy"
    (robust, no step); ``cov`` "propagated" (first order) | "chain_bootstrap"
    (:mod:`vo.rop.chain_bootstrap`), ``bootstrap_replicates`` its replicate count; ``moving_objects``
    "prior" (keep the tracks of the rigid motion nearest the motion prior when several compete,
    :mod:`vo.rop.moving`) | "none" (seed 000: all tracks), ``moving_min_fraction`` a motion competes with
    at least this fraction of the triangulated tracks, ``moving_reproj_px`` its inlier threshold (px);
    ``moving_prior`` the prediction that selects the motion: "pnp" (constant velocity of the track filter's
    PnP poses) | "velocity" (constant velocity of the estimator's poses); ``moving_step_gate_m`` a ROP
    step farther than this (m) from the track filter's PnP pose fails the frame, which then takes the PnP
    pose; ``moving_prior_gate_m`` that PnP pose stands for a failed frame only within this distance (m)
    of the prediction (:mod:`vo.rop.estimator`); ``pnp_rotation_test`` a ROP step whose rotation
    differs from that PnP pose's fails the frame likewise: "chi2" when the difference's Mahalanobis distance in
    the sum of both fits' covariances exceeds the ``chi2_3(pnp_rotation_prob)`` quantile
    (:mod:`vo.rop.rotation_test`), "degrees" when it exceeds ``pnp_rotation_gate_deg``
    (:func:`vo.rop.weak_frame.rotation_miss`); ``pnp_rotation_action`` what such a step becomes: "direction" the PnP
    rotation and translation direction with the length of seed 000's translation step re-solved for that rotation,
    "rotation" the PnP rotation with that re-solved translation (:func:`vo.rop.rotation_test.readjusted_step`),
    "pose" the PnP pose and a new keyframe; ``predict_tracks`` searches a track the zero-flow temporal LK loses
    again from its predicted pixel (:mod:`vo.rop.track_start`; not in seed 000 or 003).
    Experimental (:data:`EXPERIMENTAL`, given as ``experimental.<field>``): ``weights``, ``klt_refine``,
    ``rop_loss``, ``moving_prior``."""

    frontend: Literal[FRONTENDS] = "klt"
    ransac_threshold_px: float = knob(1.0, gt=0)
    ransac_max_iters: int = knob(200, ge=1)
    ransac_prob: float = knob(0.999, gt=0, lt=1)
    seed: int = knob(0, ge=0)
    min_matches: int = knob(30, ge=8)
    min_rop_inliers: int = knob(20, ge=5)
    min_inlier_ratio: float = knob(0.5, ge=0, le=1)
    max_rop_rotation_deg: float = knob(1.0, gt=0)
    weights: Literal[WEIGHTINGS] = "inliers"
    min_parallax_px: float = knob(0.75, ge=0)
    keyframe_baseline_ratio: float = knob(2.0, gt=0)
    keyframe_min_track_ratio: float = knob(0.5, ge=0, le=1)
    klt_config: KltConfig = knob(default_factory=KltConfig, parse=_klt_config)
    klt_refine: Literal[KltFourView.REFINES] = "translation"
    zncc_texture_snr: float = knob(2.0, ge=0)
    rop_loss: Literal[LOSSES] = "gate"
    cov: Literal[COVS] = "propagated"
    bootstrap_replicates: int = knob(40, ge=MIN_REPLICATES)
    moving_objects: Literal[MOVING] = "prior"
    moving_min_fraction: float = knob(0.1, gt=0, le=1)
    moving_reproj_px: float = knob(2.0, gt=0)
    moving_prior: Literal[MOVING_PRIORS] = "pnp"
    moving_prior_gate_m: float = knob(0.5, gt=0)
    moving_step_gate_m: float = knob(0.3, gt=0)
    pnp_rotation_test: Literal[ROTATION_TESTS] = "chi2"
    pnp_rotation_prob: float = knob(0.99, gt=0, lt=1)
    pnp_rotation_action: Literal[ROTATION_ACTIONS] = "direction"
    pnp_rotation_gate_deg: float = knob(0.2, gt=0)
    predict_tracks: bool = True

    def __post_init__(self):
        check_fields(self, EstimatorError, "rop.")

    @classmethod
    def from_options(cls, options: dict) -> "RopConfig":
        """``--opt`` / YAML mapping of field names -> :class:`RopConfig` (unknown keys name the valid ones); the
        fields in :data:`EXPERIMENTAL` are given as ``experimental.<field>``."""
        return from_mapping(cls, resolve_experimental(options, EXPERIMENTAL, "rop"), EstimatorError, "rop")

