"""Reader API: estimators read every dataset (ours or real EuRoC/KITTI) through this."""
from vo.dataset.types import Gcp, ImuData, StereoFrame  # noqa: F401
