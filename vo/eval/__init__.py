"""Trajectory evaluation: association, alignment, ATE/RPE, seed 000 drift and GCP table, KITTI metric.

Never imports mujoco. Plots live in :mod:`vo.eval.plots` (imported on demand; needs matplotlib).
"""
from vo.eval.align import ALIGN_METHODS, AlignInfo, align, apply_alignment, umeyama
from vo.eval.associate import associate, interpolate, interpolate_T
from vo.eval.coverage import Coverage, coverage
from vo.eval.evaluate import EvalResult, evaluate
from vo.eval.frames import frame_warning
from vo.eval.metrics import (ApeResult, DriftResult, ErrorStats, GcpRow, GcpTable, KittiResult, RpeResult, ate,
                             drift, gcp_errors, kitti_errors, route_lengths, rpe)

__all__ = ["Coverage", "coverage", "frame_warning", "ALIGN_METHODS", "AlignInfo", "align", "apply_alignment", "umeyama", "associate", "interpolate",
           "interpolate_T", "EvalResult", "evaluate", "ApeResult", "DriftResult", "ErrorStats", "GcpRow",
           "GcpTable", "KittiResult", "RpeResult", "ate", "drift", "gcp_errors", "kitti_errors", "route_lengths",
           "rpe"]
