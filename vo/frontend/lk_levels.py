"""OpenCV's pyramidal LK on pyramids built once per image, to the same bits as ``cv2.calcOpticalFlowPyrLK``.

OpenCV's Python binding of ``calcOpticalFlowPyrLK`` does not accept the pyramids of
``cv2.buildOpticalFlowPyramid`` (a list is refused as ``prevImg``), so every call rebuilds both images'
pyramids, also when a front-end tracks a few points forward and back between the same images (measured on
9 points: 2.03 against 1.76 ms per frame, docs/estimators.md "`rop`'s CPU time per frame").
:func:`lk_native_levels` runs the same algorithm from pyramids built once (:class:`RawPyramidCache`): one
``maxLevel=0`` call per level, coarsest first, as OpenCV's own level loop does it (its
``LKTrackerInvoker``): at the coarsest level the points and the initial flow scaled by ``2^-level``, below it
the previous level's result times 2 (float32 products by powers of two: exact), and the status of the finest
level (a point failing at a coarser level keeps its position and is tried again at the next, in OpenCV's
loop too). The levels are OpenCV's: ``cv2.pyrDown`` (``BORDER_REFLECT_101``) while the next level stays
larger than the window, as ``buildOpticalFlowPyramid`` stops; each call pads and differentiates its level
as OpenCV's loop does. ``tests/test_frontend_lk_levels.py`` checks equality with ``calcOpticalFlowPyrLK``
to the bit.

Shapes: points (N,1,2) float32 pixels (u, v); status (N,1) uint8; pyramids lists of (H_l, W_l) uint8
images, finest first.
"""
from __future__ import annotations

import cv2
import numpy as np


def raw_pyramid(img: np.ndarray, max_level: int, win: int) -> list:
    """``img`` (H,W) uint8 and its ``cv2.pyrDown`` levels, finest first, up to ``max_level`` and while a level
    stays larger than ``win`` (``cv2.buildOpticalFlowPyramid``'s rule) -> list of uint8 images."""
    out = [np.ascontiguousarray(img)]
    while len(out) <= max_level:
        h, w = out[-1].shape[:2]
        if (w + 1) // 2 <= win or (h + 1) // 2 <= win:
            break
        out.append(cv2.pyrDown(out[-1]))
    return out


class RawPyramidCache:
    """The :func:`raw_pyramid` of the last ``size`` images seen (by identity, as
    :class:`vo.frontend.lk_normalized.PyramidCache`): ``cache(img)``, built once per image."""

    def __init__(self, max_level: int, win: int, size: int = 3):
        self.max_level, self.win, self.size = max_level, win, size
        self._items: list = []           # (image, pyramid), newest last

    def __call__(self, img: np.ndarray) -> list:
        for im, pyr in self._items:
            if im is img:
                return pyr
        pyr = raw_pyramid(img, self.max_level, self.win)
        self._items = (self._items + [(img, pyr)])[-self.size:]
        return pyr


def lk_native_levels(pyr0: list, pyr1: list, pts: np.ndarray, win: int, criteria: tuple,
                     guess: np.ndarray | None = None) -> tuple:
    """``cv2.calcOpticalFlowPyrLK(pyr0[0], pyr1[0], pts, guess, winSize=(win, win), maxLevel=len(pyr0) - 1,
    criteria=criteria[, flags=OPTFLOW_USE_INITIAL_FLOW when guess is given])`` from pre-built pyramids of the
    same number of levels -> ``(next_pts (N,1,2) float32, status (N,1) uint8)`` (module docstring)."""
    a = np.ascontiguousarray(pts, np.float32).reshape(-1, 1, 2)
    top = len(pyr0) - 1
    b = a if guess is None else np.ascontiguousarray(guess, np.float32).reshape(-1, 1, 2)
    b = b * np.float32(1.0 / (1 << top))
    for level in range(top, -1, -1):
        a_l = a * np.float32(1.0 / (1 << level))
        b, st, _ = cv2.calcOpticalFlowPyrLK(pyr0[level], pyr1[level], a_l, b, winSize=(win, win), maxLevel=0,
                                            criteria=criteria, flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
        if level:
            b = b * np.float32(2.0)
    return b, st
