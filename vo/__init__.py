"""Estimators, evaluation metrics and error-propagation models. Never imports mujoco."""
from vo.errors import VoError, DatasetError, EstimatorError  # noqa: F401
from rigs.trajectory import Trajectory  # noqa: F401
