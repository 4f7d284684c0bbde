"""Shared pieces of the stereo PnP estimators: configuration, PnP with RANSAC + LM refinement.

Poses: ``T_o_c0`` left camera in the frame ``o`` of the first left camera; PnP returns ``T_c0_o``
(OpenCV's rvec/tvec map object points into the camera), inverted at the boundary in :func:`solve_pnp`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from rigs.geometry import inv_T, make_T, transform_points
from rigs.geometry.pinhole import project
from rigs.typed_config import check_fields, knob
from vo.errors import EstimatorError
from vo.frontend.image import to_gray  # noqa: F401  (re-exported: the estimators' grey conversion)

PNP_METHODS = {"iterative": cv2.SOLVEPNP_ITERATIVE, "epnp": cv2.SOLVEPNP_EPNP}


@dataclass(frozen=True)
class PnpConfig:
    """``method`` RANSAC minimal solver (iterative | epnp); ``ransac_reproj_px`` inlier threshold on
    undistorted pixels; ``ransac_iters``, ``confidence``; ``min_features`` fewer tracked landmarks ->
    status few_features; ``min_pnp_inliers`` fewer inliers -> lost; ``min_init_landmarks`` stereo
    landmarks needed to (re)initialise; ``max_depth`` m and ``max_triangulation_px`` triangulation checks;
    ``max_step_m`` largest believable camera motion between frames (m) before the frame is declared lost."""

    method: Literal[tuple(PNP_METHODS)] = "epnp"
    ransac_reproj_px: float = knob(2.0, gt=0)
    ransac_iters: int = knob(200, ge=1)
    confidence: float = knob(0.999, gt=0, lt=1)
    min_features: int = knob(15, ge=6)
    min_pnp_inliers: int = knob(10, ge=4)
    min_init_landmarks: int = knob(20, ge=6)
    max_depth: float = knob(80.0, gt=0)
    max_triangulation_px: float = knob(1.0, gt=0)
    max_step_m: float = knob(5.0, gt=0)

    def __post_init__(self):
        check_fields(self, EstimatorError, "pnp.")


def solve_pnp(p_o: np.ndarray, x_undist: np.ndarray, K: np.ndarray, config: PnpConfig) -> tuple:
    """3-D landmarks ``p_o`` (N,3) seen at undistorted pixels ``x_undist`` (N,2) -> ``(T_o_c0 | None, inliers (N,) bool)``.

    ``cv2.solvePnPRansac`` (minimal solver ``config.method``) then ``cv2.solvePnPRefineLM`` on the inliers.
    """
    n = len(p_o)
    inl = np.zeros(n, bool)
    if n < max(6, config.min_pnp_inliers):
        return None, inl
    obj = np.ascontiguousarray(p_o, dtype=np.float64).reshape(-1, 1, 3)
    img = np.ascontiguousarray(x_undist, dtype=np.float64).reshape(-1, 1, 2)
    try:
        ok, rvec, tvec, idx = cv2.solvePnPRansac(obj, img, K, None, iterationsCount=config.ransac_iters,
                                                 reprojectionError=config.ransac_reproj_px,
                                                 confidence=config.confidence, flags=PNP_METHODS[config.method])
    except cv2.error:
        return None, inl
    if not ok or idx is None or len(idx) < config.min_pnp_inliers:
        return None, inl
    inl[idx.reshape(-1)] = True
    try:
        rvec, tvec = cv2.solvePnPRefineLM(obj[inl], img[inl], K, None, rvec, tvec)
    except cv2.error:
        pass
    T_c0_o = make_T(cv2.Rodrigues(rvec)[0], tvec.reshape(3))
    if not np.all(np.isfinite(T_c0_o)):
        return None, np.zeros(n, bool)
    # inliers of the refined pose (in front of the camera, reprojection below the RANSAC threshold)
    p_c = transform_points(T_c0_o, p_o)
    inl = p_c[:, 2] > 0
    inl[inl] = np.linalg.norm(project(p_c[inl], K) - img.reshape(-1, 2)[inl], axis=1) < config.ransac_reproj_px
    if inl.sum() < config.min_pnp_inliers:
        return None, inl
    return inv_T(T_c0_o), inl
