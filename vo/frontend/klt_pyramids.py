"""The image pyramids of a KLT front-end, each built once per image, and OpenCV's raw-image LK run on them.

``cv2.calcOpticalFlowPyrLK`` given two images builds both pyramids on every call; the KLT front-end's raw
fallback (:func:`vo.frontend.klt.track_fb`) calls it twice per image pair (forward and back), and each image
takes part in two pairs, so every raw pyramid was built four times. :class:`LkPyramids` keeps the last images'
pyramids (normalised, :class:`~vo.frontend.lk_normalized.PyramidCache`, and raw, :func:`raw_pyramid`) and
:func:`lk_raw_levels` runs OpenCV's LK on the raw ones level by level, doing exactly what OpenCV does inside
(its Python interface takes no pyramid): the same levels (``cv2.pyrDown``, as ``cv2.buildOpticalFlowPyramid``,
which stops before a level no larger than the window), each point at ``p0 * 2^-level`` in float32, its flow
doubled between levels in float32 and started from the coarsest level, a point lost on a coarse level
carried on with the flow it had, its status the finest level's. The result equals OpenCV's to the bit
(``tests/test_klt_pyramids.py``).

Shapes: ``p0``, ``guess`` (N,2) pixels (u, v); pyramids are lists of (H_l, W_l) uint8 images, finest first.
"""
from __future__ import annotations

import cv2
import numpy as np

from vo.frontend.lk_normalized import PyramidCache


def raw_pyramid(img: np.ndarray, win: int, max_level: int) -> list:
    """The levels ``cv2.calcOpticalFlowPyrLK(..., winSize=(win, win), maxLevel=max_level)`` builds from
    ``img`` (H,W): halved by ``cv2.pyrDown`` while the next level is larger than the window, at most
    ``max_level`` times -> list of images, finest first."""
    out = [img]
    h, w = img.shape[:2]
    for _ in range(max_level):
        h, w = (h + 1) // 2, (w + 1) // 2
        if w <= win or h <= win:
            break
        out.append(cv2.pyrDown(out[-1]))
    return out


def lk_raw_levels(pyr0: list, pyr1: list, p0: np.ndarray, win: int, iters: int, eps: float,
                  guess: np.ndarray | None = None) -> tuple:
    """``cv2.calcOpticalFlowPyrLK`` of ``p0`` from the images of ``pyr0`` to those of ``pyr1`` (:func:`raw_pyramid`
    of both, same window and levels), started at ``guess`` (default: zero flow) -> its ``(p1 (N,1,2) float32,
    status (N,1) uint8)``."""
    a0 = np.ascontiguousarray(np.asarray(p0, np.float64).reshape(-1, 1, 2), np.float32)
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iters, eps)
    top = min(len(pyr0), len(pyr1)) - 1
    nxt = None if guess is None else np.ascontiguousarray(np.asarray(guess).reshape(-1, 1, 2), np.float32)
    st = np.zeros((len(a0), 1), np.uint8)
    for level in range(top, -1, -1):
        scale = np.float32(1.0 / (1 << level))
        prev = a0 * scale
        if level == top:
            start = prev.copy() if nxt is None else nxt * scale
        else:
            start = nxt * np.float32(2.0)
        nxt, st, _ = cv2.calcOpticalFlowPyrLK(pyr0[level], pyr1[level], prev, start, winSize=(win, win),
                                              maxLevel=0, criteria=crit, flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
    return nxt, st


def lk_raw(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, win: int, max_level: int, iters: int, eps: float,
           guess: np.ndarray | None = None, pyramids: tuple | None = None) -> tuple:
    """OpenCV's pyramidal LK of ``p0`` (N,2) or (N,1,2) from the raw image ``img0`` into ``img1``, started at
    ``guess`` (same shapes; None: zero flow) -> ``(p1 (N,1,2) float32, status (N,1) uint8)``: from the two
    images' raw pyramids ``pyramids`` (:meth:`LkPyramids.raw`) when given, else ``cv2.calcOpticalFlowPyrLK`` on
    the images; the same bits either way."""
    start = None if guess is None else np.array(guess, np.float32).reshape(-1, 1, 2)
    if pyramids is not None:
        return lk_raw_levels(*pyramids, p0, win, iters, eps, start)
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iters, eps)
    a = np.ascontiguousarray(np.asarray(p0).reshape(-1, 1, 2), np.float32)
    p1, st, _ = cv2.calcOpticalFlowPyrLK(img0, img1, a, start, winSize=(win, win), maxLevel=max_level, criteria=crit,
                                         flags=0 if start is None else cv2.OPTFLOW_USE_INITIAL_FLOW)
    return p1, st


class LkPyramids:
    """The pyramids of the last ``size`` images seen (by identity, as :class:`PyramidCache`): called with an
    image, its normalised pyramid (``levels``, ``box``); :meth:`raw`, its raw pyramid (:func:`raw_pyramid`)."""

    def __init__(self, levels: int, box: int, size: int = 3):
        self.normalized = PyramidCache(levels, box, size)
        self.size = size
        self._raw: list = []             # (image, win, max_level, pyramid), newest last

    def __call__(self, img: np.ndarray) -> list:
        return self.normalized(img)

    def raw(self, img: np.ndarray, win: int, max_level: int) -> list:
        for im, w, m, pyr in self._raw:
            if im is img and w == win and m == max_level:
                return pyr
        pyr = raw_pyramid(img, win, max_level)
        self._raw = (self._raw + [(img, win, max_level, pyr)])[-self.size:]
        return pyr
