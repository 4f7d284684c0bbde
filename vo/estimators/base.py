"""The estimator interface: a plug-in consumes stereo frames (and optionally IMU) and emits poses.

Output poses are ``T_o_c0``: the left camera in the frame ``o`` of the first left camera
(seed 000's object frame O). Evaluation anchors ``o`` to the world with the true first pose.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from rigs.model import Rig
from rigs.records import ImuSamples, StereoFrame

STATUSES = ("init", "ok", "keyframe", "few_features", "lost", "reinit")
# What a frame's pose is worth, whatever the estimator's own status word:
#   ok       - computed from this frame's measurements (or the origin the estimator defines on its first frame);
#   coasting - predicted without a measurement (constant-velocity extrapolation after a failed frame);
#   init     - a placeholder before the estimator has any pose (e.g. a VINS still collecting keyframes);
#   lost     - a placeholder after tracking failed (the last pose held).
# Evaluation and the gate use the produced classes only (ok and coasting: a user counts a coasted pose as
# produced, and it is reported separately); init and lost count as not covered.
FRAME_CLASSES = ("ok", "coasting", "init", "lost")
PRODUCED_CLASSES = ("ok", "coasting")
STATUS_CLASS = {"init": "init", "ok": "ok", "keyframe": "ok", "reinit": "ok", "few_features": "lost", "lost": "lost"}
MAX_COAST_FRAMES = 10    # failed frames extrapolated at constant velocity before the translation is held


@dataclass
class FrameResult:
    """What an estimator says about one frame.

    ``T_o_c0`` (4,4) is always finite (on failure: the last good pose propagated, never NaN);
    ``cov`` (6,6) optional covariance of ``[rotation vector (rad), position (m)]`` of ``T_o_c0``
    (rotation perturbation on the left: ``R = exp(dphi) R_hat``);
    ``status`` one of :data:`STATUSES`; ``message`` says why in words (e.g. "12 features < 30: white wall?");
    ``pose_class`` one of :data:`FRAME_CLASSES`, what the pose is worth; "" (a plug-in that does not say)
    takes :data:`STATUS_CLASS` of the status (a failed frame then counts as a held placeholder).
    """

    t_ns: int
    T_o_c0: np.ndarray
    status: str = "ok"
    n_features: int = 0
    n_inliers: int = 0
    cov: Optional[np.ndarray] = None
    message: str = ""
    timings_ms: dict = field(default_factory=dict)
    pose_class: str = ""


def frame_class(res: FrameResult) -> str:
    """The :data:`FRAME_CLASSES` entry of ``res``: its ``pose_class``, else the one its status implies."""
    return res.pose_class or STATUS_CLASS[res.status]


class Estimator(abc.ABC):
    """Base class of every VO / VINS estimator. Subclasses set ``name`` and implement ``process``."""

    name: str = ""

    def __init__(self, rig: Rig, **options):
        self.rig = rig
        self.options = options

    def set_imu(self, imu: Optional[ImuSamples]) -> None:
        """Give the whole IMU stream up front (VINS estimators use it; VO ignores it)."""

    @classmethod
    def is_oracle(cls, options: dict) -> bool:
        """True when this estimator, with ``options``, reads ground truth (an oracle, for studies): only then
        does :meth:`set_dataset` get the whole dataset, and ``check`` refuses it. Default: False."""
        return False

    def set_dataset(self, dataset) -> None:
        """The dataset, before the first frame, for estimators that read more than frames and IMU. The runner
        hands a sensor-only :class:`vo.estimators.sensor_dataset.SensorDataset` unless :meth:`is_oracle` (e.g.
        ``vins-oracle`` reads the true segmentation); default: nothing."""

    @abc.abstractmethod
    def process(self, frame: StereoFrame) -> FrameResult:
        """Consume one stereo frame, return the pose of the left camera at ``frame.t_ns``."""
