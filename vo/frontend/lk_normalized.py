"""Pyramidal Lucas-Kanade on local-mean-normalised pyramids: seed 003's intensity-invariant residual
(section 5.2) at OpenCV's speed.

Seed 003 divides each patch by its mean before comparing it, ``r_i = I1(x_i + d) / mean(I1 patch) -
I0(x_i) / mean(I0 patch)``, so that a brightness change between the images does not bias the flow
(:mod:`vo.frontend.lk_invariant` implements that residual point by point in numpy: ~15x slower than
OpenCV's LK). Here every pyramid level of each image is divided, pixel by pixel, by the mean of the
``box x box`` window centred on the pixel (``box`` = ``normalize_box`` x the LK window, at that level),
rescaled to 8 bits (``NORMALIZED_SCALE`` grey levels = the local mean), and OpenCV's LK then runs level
by level from the coarsest (``maxLevel=0`` on each, the flow doubled between levels, as in its own
pyramid). Under a gain field ``I = g(x) R(x)`` that is constant over the window the normalised images of
two views agree exactly, as seed 003's normalised patches do; where the gain varies across the window
(vignetting: the cos^4 fall-off of the ``realistic`` camera varies by up to ~15 % across a 21 px window at
the coarsest of 4 levels, 168 px of the full image) the per-pixel mean removes its slope too, which one
mean per patch cannot. The normalisation is applied per level, not once to the full image: a full-image
high-pass leaves the coarse levels (where large disparities and fast rotations are found) without
texture.

Shapes: ``p0``, ``p1``, ``guess`` (N,2) float64 pixels (u, v); ``ok`` (N,) bool; pyramids are lists of
(H_l, W_l) uint8 images, finest first.
"""
from __future__ import annotations

import cv2
import numpy as np

NORMALIZED_SCALE = 80.0      # 8-bit value of a pixel equal to its local mean (ratios up to 3.2 before clipping)


def normalized_pyramid(img: np.ndarray, levels: int, box: int) -> list:
    """``levels`` levels (finest first) of ``img`` (H,W), each divided by its ``box x box`` local mean
    (odd ``box``, reflected borders) and scaled by :data:`NORMALIZED_SCALE` -> list of uint8 images."""
    f = np.asarray(img, np.float32)
    out = []
    for level in range(levels):
        if level:
            f = cv2.pyrDown(f)
        mean = cv2.max(cv2.blur(f, (box, box), borderType=cv2.BORDER_REFLECT), 1.0)
        out.append(cv2.divide(f, mean, scale=NORMALIZED_SCALE, dtype=cv2.CV_8U))     # rounded, saturated
    return out


class PyramidCache:
    """The normalised pyramids of the last ``size`` images seen (by identity: a front-end passes the same
    array for the frame's left image to its temporal and stereo calls, and again as the previous image next
    frame): ``cache(img)`` -> :func:`normalized_pyramid` ``(img, levels, box)``, built once per image."""

    def __init__(self, levels: int, box: int, size: int = 3):
        self.levels, self.box, self.size = levels, box, size
        self._items: list = []           # (image, pyramid), newest last; the image is kept so its id stays valid

    def __call__(self, img: np.ndarray) -> list:
        for im, pyr in self._items:
            if im is img:
                return pyr
        pyr = normalized_pyramid(img, self.levels, self.box)
        self._items = (self._items + [(img, pyr)])[-self.size:]
        return pyr


def lk_pyramids(pyr0: list, pyr1: list, p0: np.ndarray, win: int, iters: int, eps: float,
                guess: np.ndarray | None = None) -> tuple:
    """Coarse-to-fine LK of ``p0`` (pixels of level 0 of ``pyr0``) into ``pyr1`` (same number of levels),
    started at ``guess`` (default: zero flow) -> ``(p1 (N,2), ok (N,))``. A point failing at a coarse level
    keeps its flow and is tried at the next (OpenCV's own pyramid does the same); ``ok`` is OpenCV's status
    at full resolution, finite, inside the image."""
    p0 = np.asarray(p0, np.float64).reshape(-1, 2)
    n = len(p0)
    if n == 0:
        return np.zeros((0, 2)), np.zeros(0, bool)
    top = len(pyr0) - 1
    d = (np.zeros_like(p0) if guess is None else np.asarray(guess, np.float64).reshape(-1, 2) - p0) / 2.0 ** top
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iters, eps)
    st = np.zeros(n, np.uint8)
    for level in range(top, -1, -1):
        a = np.ascontiguousarray(p0 / 2.0 ** level, np.float32).reshape(-1, 1, 2)
        b = np.ascontiguousarray(a.reshape(-1, 2) + d, np.float32).reshape(-1, 1, 2)
        b, st, _ = cv2.calcOpticalFlowPyrLK(pyr0[level], pyr1[level], a, b, winSize=(win, win), maxLevel=0,
                                            criteria=crit, flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
        d = b.reshape(-1, 2).astype(np.float64) - a.reshape(-1, 2)
        if level:
            d *= 2.0
    p1 = p0 + d
    h, w = pyr1[0].shape[:2]
    ok = (st.ravel() == 1) & np.all(np.isfinite(p1), axis=1)
    ok &= (p1[:, 0] >= 0) & (p1[:, 1] >= 0) & (p1[:, 0] <= w - 1) & (p1[:, 1] <= h - 1)
    return p1, ok


def mirrored_start(p1: np.ndarray, guess: np.ndarray, p0: np.ndarray) -> np.ndarray:
    """The backward LK's start for a forward search started at a prediction ``guess`` (N,2) from ``p0`` (N,2) that
    ended at ``p1`` (N,2): the guess mirrored through the forward result, ``p1 - (guess - p0)``, as far from ``p0``
    as ``p1`` lies from its guess, so that the round trip stays a test of the match -> (N,2) float64. Used by
    :func:`vo.frontend.klt.track_fb` and the four-view front-end of ``rop``."""
    return np.asarray(p1, np.float64).reshape(-1, 2) - (np.asarray(guess, np.float64).reshape(-1, 2)
                                                          - np.asarray(p0, np.float64).reshape(-1, 2))


def lk_fb_pyramids(pyr0: list, pyr1: list, p0: np.ndarray, win: int, iters: int, eps: float, fb_threshold_px: float,
                   guess: np.ndarray | None = None, mirror: bool = False) -> tuple:
    """:func:`lk_pyramids` forward, then back from the result (started at ``p0``, or with ``mirror`` and a
    ``guess`` at :func:`mirrored_start`); ``ok`` where both converge and the round trip ends < ``fb_threshold_px``
    from ``p0`` -> ``(p1 (N,2), ok (N,))``."""
    p0 = np.asarray(p0, np.float64).reshape(-1, 2)
    p1, ok_f = lk_pyramids(pyr0, pyr1, p0, win, iters, eps, guess)
    if len(p0) == 0:
        return p1, ok_f
    back = np.where(ok_f[:, None], p1, p0)
    start = mirrored_start(back, guess, p0) if mirror and guess is not None else p0
    pb, ok_b = lk_pyramids(pyr1, pyr0, back, win, iters, eps, start)
    return p1, ok_f & ok_b & (np.linalg.norm(pb - p0, axis=1) < fb_threshold_px)
