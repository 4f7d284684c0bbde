"""Estimators, evaluation metrics and error-propagation models. Never imports mujoco."""
from vo.errors import VoError, DatasetError, EstimatorError  # noqa: F401
from vo.trajectory import Trajectory  # noqa: F401
