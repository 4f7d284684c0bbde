"""Wallis filter, seed 001 eq. 1: ``g_o = g r1 + r0`` with ``r1 = c s_f / (c s_g + s_f / c)`` and
``r0 = b m_f + (1 - b - r1) m_g``.

The paper prints ``r0 = b m_f + (1 + b + r1) m_g``, which is garbled: with it a flat image
(``s_g = 0``) of mean ``m_g`` would not map to ``b m_f + (1 - b) m_g``. The standard form (Zhang et
al. 1999) used here gives the output mean ``b m_f + (1 - b) m_g`` exactly (``m_f`` when b = 1) and the
output standard deviation ``r1 s_g = c s_f s_g / (c s_g + s_f / c)``, which tends to ``s_f`` as the
contrast expansion constant ``c`` grows. ``m_g``, ``s_g`` are the statistics of a local window
(``window_px``) or, with ``window_px=None``, of the whole image.
"""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np

from vo.errors import VoError


def wallis_coefficients(m_g, s_g, m_f: float, s_f: float, b: float, c: float):
    """(r1, r0) of eq. 1 (corrected r0) for input statistics ``m_g``, ``s_g`` (scalars or arrays)."""
    if s_f <= 0 or c <= 0 or not 0 <= b <= 1:
        raise VoError(f"wallis: need s_f > 0, c > 0, 0 <= b <= 1; got s_f={s_f}, c={c}, b={b}")
    r1 = c * s_f / (c * np.asarray(s_g, float) + s_f / c)
    r0 = b * m_f + (1.0 - b - r1) * np.asarray(m_g, float)
    return r1, r0


def local_stats(img: np.ndarray, window_px: Optional[int]):
    """(mean, std) of ``img`` over a ``window_px`` box around each pixel, or global scalars."""
    g = np.asarray(img, dtype=np.float64)
    if window_px is None:
        return float(g.mean()), float(g.std())
    if window_px < 3 or window_px % 2 == 0:
        raise VoError(f"wallis.window_px: expected an odd size >= 3, got {window_px!r}")
    k = (int(window_px), int(window_px))
    m = cv2.boxFilter(g, cv2.CV_64F, k, borderType=cv2.BORDER_REFLECT)
    m2 = cv2.boxFilter(g * g, cv2.CV_64F, k, borderType=cv2.BORDER_REFLECT)
    return m, np.sqrt(np.maximum(m2 - m * m, 0.0))


def wallis(img: np.ndarray, m_f: float, s_f: float, b: float = 1.0, c: float = 4.0,
           window_px: Optional[int] = 31, out_float: bool = False) -> np.ndarray:
    """Eq. 1 applied to ``img`` with target mean ``m_f`` and std ``s_f``; uint8 (clipped) unless
    ``out_float``."""
    m_g, s_g = local_stats(img, window_px)
    r1, r0 = wallis_coefficients(m_g, s_g, m_f, s_f, b, c)
    out = np.asarray(img, dtype=np.float64) * r1 + r0
    return out if out_float else np.clip(np.rint(out), 0, 255).astype(np.uint8)


def match_statistics(img_prev: np.ndarray, img_cur: np.ndarray, b: float, c: float, window_px: int,
                     mask_prev=None, mask_cur=None) -> tuple:
    """§2.2: both images filtered towards the current image's statistics (inside its region
    ``mask_cur``), so that the previous site's grey levels follow the current site's."""
    sel = img_cur[mask_cur > 0] if mask_cur is not None and np.any(mask_cur) else img_cur.ravel()
    m_f, s_f = float(sel.mean()), max(float(sel.std()), 1.0)
    return (wallis(img_prev, m_f, s_f, b, c, window_px), wallis(img_cur, m_f, s_f, b, c, window_px))
