"""Descriptor front-end: ORB or SIFT key points, Lowe ratio test and mutual-nearest-neighbour cross-check.

Seed 000 uses SURF; SURF is patented and absent from OpenCV's free build (``cv2.xfeatures2d`` is not
in opencv-python-headless), so SIFT (``cv2.SIFT_create``, free since OpenCV 4.4) substitutes for it.
Seed 003's descriptor baseline is ORB.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vo.errors import VoError
from vo.frontend.stereo import epipolar_mask

KINDS = ("orb", "sift")


@dataclass(frozen=True)
class DescriptorConfig:
    """``n_features`` per image, ``ratio`` Lowe ratio (best < ratio * second best), ``cross_check``
    mutual nearest neighbours, ``epipolar_threshold_px`` for :func:`match_stereo`."""

    n_features: int = 2000
    ratio: float = 0.8
    cross_check: bool = True
    epipolar_threshold_px: float = 1.0

    def __post_init__(self):
        if self.n_features < 1 or not 0 < self.ratio <= 1 or self.epipolar_threshold_px <= 0:
            raise VoError(f"DescriptorConfig: invalid values n_features={self.n_features!r} ratio={self.ratio!r} "
                          f"epipolar_threshold_px={self.epipolar_threshold_px!r} (need >=1, (0,1], >0)")


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise VoError(f"descriptor kind {kind!r} unknown; valid: {', '.join(KINDS)}")


def detect_and_describe(img: np.ndarray, kind: str = "orb", config: DescriptorConfig = DescriptorConfig()) -> tuple:
    """-> ``(pts (N,2) float64 pixels, desc (N,D) uint8 for ORB / float32 for SIFT)``."""
    _check_kind(kind)
    det = cv2.ORB_create(nfeatures=config.n_features) if kind == "orb" else cv2.SIFT_create(nfeatures=config.n_features)
    kps, desc = det.detectAndCompute(np.ascontiguousarray(img), None)
    if desc is None or not kps:
        return np.zeros((0, 2)), np.zeros((0, 32 if kind == "orb" else 128), np.uint8 if kind == "orb" else np.float32)
    return np.array([k.pt for k in kps], dtype=np.float64), desc


def match_descriptors(desc_a: np.ndarray, desc_b: np.ndarray, kind: str = "orb",
                      config: DescriptorConfig = DescriptorConfig()) -> np.ndarray:
    """-> (M,2) int index pairs ``(i_a, i_b)`` passing the ratio test (both directions when cross-checking)
    and, with ``cross_check``, mutual nearest neighbours."""
    _check_kind(kind)
    if len(desc_a) < 2 or len(desc_b) < 2:
        return np.zeros((0, 2), int)
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING if kind == "orb" else cv2.NORM_L2)
    ab = _ratio_best(matcher.knnMatch(desc_a, desc_b, k=2), len(desc_a), config.ratio)
    if config.cross_check:
        ba = _ratio_best(matcher.knnMatch(desc_b, desc_a, k=2), len(desc_b), config.ratio)
        i_a = np.flatnonzero(ab >= 0)
        i_a = i_a[ba[ab[i_a]] == i_a]
    else:
        i_a = np.flatnonzero(ab >= 0)
    return np.column_stack([i_a, ab[i_a]]).astype(int)


def _ratio_best(knn, n: int, ratio: float) -> np.ndarray:
    """(n,) index of the best match passing the ratio test, -1 otherwise."""
    best = np.full(n, -1, int)
    for m in knn:
        if len(m) == 2 and m[0].distance < ratio * m[1].distance:
            best[m[0].queryIdx] = m[0].trainIdx
    return best


def match_images(img_a: np.ndarray, img_b: np.ndarray, kind: str = "orb",
                 config: DescriptorConfig = DescriptorConfig()) -> tuple:
    """Matched pixels between two images -> ``(p_a (M,2), p_b (M,2))`` float64."""
    pa, da = detect_and_describe(img_a, kind, config)
    pb, db = detect_and_describe(img_b, kind, config)
    ij = match_descriptors(da, db, kind, config)
    return pa[ij[:, 0]], pb[ij[:, 1]]


def match_stereo(left: np.ndarray, right: np.ndarray, kind: str = "orb", rig=None,
                 config: DescriptorConfig = DescriptorConfig()) -> tuple:
    """Left/right matches, with the calibrated epipolar check when ``rig`` is given -> ``(p_left, p_right)``."""
    p_l, p_r = match_images(left, right, kind, config)
    if rig is not None and len(p_l):
        ok = epipolar_mask(rig, p_l, p_r, config.epipolar_threshold_px)
        p_l, p_r = p_l[ok], p_r[ok]
    return p_l, p_r
