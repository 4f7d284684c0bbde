"""Exceptions of the ``vo`` package (under the project root :class:`rigs.errors.TestbedError`)."""
from rigs.errors import TestbedError


class VoError(TestbedError):
    """Base of every error raised by ``vo``; messages name the file, field or bad value."""


class DatasetError(VoError):
    """A dataset folder is missing, partial, marked incomplete, or malformed."""


class EstimatorError(VoError):
    """An estimator name is unknown or an estimator failed irrecoverably."""
