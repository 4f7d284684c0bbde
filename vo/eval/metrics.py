"""All trajectory metrics in one place (each lives in its own module)."""
from vo.eval.ape import ApeResult, ate
from vo.eval.drift import DriftResult, drift
from vo.eval.gcp import GcpRow, GcpTable, gcp_errors
from vo.eval.kitti_segments import KITTI_LENGTHS_M, KittiResult, kitti_errors, route_lengths
from vo.eval.rpe import RpeResult, rpe
from vo.eval.stats import ErrorStats

__all__ = ["ApeResult", "ate", "DriftResult", "drift", "GcpRow", "GcpTable", "gcp_errors", "KITTI_LENGTHS_M",
           "KittiResult", "kitti_errors", "route_lengths", "RpeResult", "rpe", "ErrorStats"]
