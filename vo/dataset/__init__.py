"""Reader API: estimators read every dataset (ours or real EuRoC/KITTI) through this."""
from rigs.records import Gcp, ImuSamples, StereoFrame, WheelSamples  # noqa: F401
from vo.dataset.base import Dataset  # noqa: F401
from vo.dataset.open import open_dataset  # noqa: F401

__all__ = ["Dataset", "Gcp", "ImuSamples", "StereoFrame", "WheelSamples", "open_dataset"]
