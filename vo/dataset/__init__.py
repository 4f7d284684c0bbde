"""Reader API: estimators read every dataset (ours or real EuRoC/KITTI) through this."""
from vo.dataset.types import Gcp, ImuData, StereoFrame, WheelData  # noqa: F401
from vo.dataset.base import Dataset  # noqa: F401
from vo.dataset.open import open_dataset  # noqa: F401

__all__ = ["Dataset", "Gcp", "ImuData", "StereoFrame", "WheelData", "open_dataset"]
