"""Stereo matching of feature points within one site (seed 001 §2.2): ZNCC along the epipolar line
inside a disparity range, a median filter on disparity, and least-squares matching (Gruen 1985).

The pair is rectified (:class:`vo.crosssite.types.StereoCal`): the epipolar line of left pixel
``(u, v)`` is row ``v`` of the right image and the disparity ``d = u_l - u_r`` lies in
``[f B / range_max, f B / range_min]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import map_coordinates
from scipy.optimize import least_squares
from scipy.spatial import cKDTree


@dataclass(frozen=True)
class StereoMatches:
    """``ok`` (N,) bool; ``uv_r`` (N,2) right-image positions (NaN where not ok); ``score`` (N,) ZNCC."""

    ok: np.ndarray
    uv_r: np.ndarray
    score: np.ndarray

    def with_left(self, uv_l: np.ndarray) -> np.ndarray:
        """(N,) disparities ``u_l - u_r``."""
        return uv_l[:, 0] - self.uv_r[:, 0]


def zncc_along_row(left: np.ndarray, right: np.ndarray, uv_l: np.ndarray, d_min: float, d_max: float,
                   half: int) -> tuple:
    """Integer-pixel ZNCC search: for each left point the right position on its row with the highest
    ``cv2.TM_CCOEFF_NORMED`` score within the disparity range. -> (u_r (N,), score (N,)), NaN/-1 where
    the window leaves an image."""
    H, W = left.shape
    L, R = left.astype(np.float32), right.astype(np.float32)
    u_r = np.full(len(uv_l), np.nan)
    score = np.full(len(uv_l), -1.0)
    for n, (u, v) in enumerate(np.rint(uv_l).astype(int)):
        if not (half <= v < H - half and half <= u < W - half):
            continue
        lo, hi = max(half, u - int(np.ceil(d_max))), min(W - half - 1, u - int(np.floor(d_min)))
        if hi < lo:
            continue
        tpl = L[v - half:v + half + 1, u - half:u + half + 1]
        if tpl.std() < 1e-3:
            continue
        strip = R[v - half:v + half + 1, lo - half:hi + half + 1]
        res = cv2.matchTemplate(strip, tpl, cv2.TM_CCOEFF_NORMED)[0]
        k = int(np.argmax(res))
        u_r[n], score[n] = lo + k + (uv_l[n, 0] - u), float(res[k])
    return u_r, score


def median_disparity_filter(uv_l: np.ndarray, disp: np.ndarray, ok: np.ndarray, k: int, abs_px: float,
                            rel: float) -> np.ndarray:
    """Di et al. 2008: a point whose disparity departs from the median of its ``k`` nearest
    neighbours (image distance) by more than ``max(abs_px, rel * median)`` is dropped."""
    keep = ok.copy()
    idx = np.flatnonzero(ok)
    if idx.size <= 2:
        return keep
    kk = min(k + 1, idx.size)
    _, nb = cKDTree(uv_l[idx]).query(uv_l[idx], k=kk)
    med = np.median(disp[idx][nb[:, 1:]], axis=1)
    keep[idx] = np.abs(disp[idx] - med) <= np.maximum(abs_px, rel * np.abs(med))
    return keep


def lsm_refine(left: np.ndarray, right: np.ndarray, uv_l, uv_r0, half: int, max_shift: float, H0=None):
    """Least-squares matching of one point: the right window is the left one under an affine map
    ``x_r = uv_r0 + s + A (x_l - uv_l)`` with a radiometric gain and offset ``h0 + h1 g``; eight
    parameters, solved by ``scipy.optimize.least_squares`` on bilinearly interpolated grey values.
    ``H0`` (3x3 map left pixel -> right pixel, default the identity) is the warp the geometry predicts:
    the left window is then sampled at ``H0^-1(H0(uv_l) + d)`` for the right window's offsets ``d``,
    i.e. resampled into the right image's geometry (the whole homography, not its affine part, whose
    neglected curvature would shift the match), and ``A`` refines what is left.
    -> refined (u_r, v_r) or None when it does not converge or moves more than ``max_shift``."""
    dy, dx = np.mgrid[-half:half + 1, -half:half + 1].astype(float)
    dx, dy = dx.ravel(), dy.ravel()
    if H0 is None:
        lx, ly = uv_l[0] + dx, uv_l[1] + dy
    else:
        H0 = np.asarray(H0, float)
        c = H0 @ np.array([uv_l[0], uv_l[1], 1.0])
        q = np.linalg.solve(H0, np.vstack([c[0] / c[2] + dx, c[1] / c[2] + dy, np.ones_like(dx)]))
        lx, ly = q[0] / q[2], q[1] / q[2]
    g_l = map_coordinates(left.astype(float), [ly, lx], order=1)
    Rf = right.astype(float)

    def resid(p):
        xs = uv_r0[0] + p[0] + (1 + p[2]) * dx + p[3] * dy
        ys = uv_r0[1] + p[1] + p[4] * dx + (1 + p[5]) * dy
        return p[6] + (1 + p[7]) * map_coordinates(Rf, [ys, xs], order=1, mode="nearest") - g_l

    p0 = np.zeros(8)
    try:
        sol = least_squares(resid, p0, method="lm", x_scale=[1, 1, .01, .01, .01, .01, 10, .1], max_nfev=200)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not sol.success or not np.all(np.isfinite(sol.x)) or np.hypot(sol.x[0], sol.x[1]) > max_shift:
        return None
    return uv_r0[0] + sol.x[0], uv_r0[1] + sol.x[1]


def match_stereo(left: np.ndarray, right: np.ndarray, uv_l: np.ndarray, f: float, baseline: float, cfg,
                 refine: bool = True) -> StereoMatches:
    """ZNCC search -> median filter on disparity -> LSM sub-pixel refinement for points ``uv_l`` (N,2)."""
    uv_l = np.asarray(uv_l, dtype=float).reshape(-1, 2)
    d_min, d_max = f * baseline / cfg.range_max_m, f * baseline / cfg.range_min_m
    u_r, score = zncc_along_row(left, right, uv_l, d_min, d_max, cfg.zncc_half_px)
    ok = score >= cfg.zncc_min
    disp = uv_l[:, 0] - u_r
    ok = median_disparity_filter(uv_l, disp, ok, cfg.median_k, cfg.median_abs_px, cfg.median_rel)
    uv_r = np.column_stack([u_r, uv_l[:, 1]])
    if refine:
        H, W = left.shape
        m = cfg.lsm_half_px + 2
        for n in np.flatnonzero(ok):
            inside = (m <= uv_r[n, 0] < W - m) and (m <= uv_l[n, 0] < W - m) and (m <= uv_l[n, 1] < H - m)
            r = lsm_refine(left, right, uv_l[n], uv_r[n], cfg.lsm_half_px, cfg.lsm_max_shift_px) if inside else None
            if r is None:
                ok[n] = False
            else:
                uv_r[n] = r
    uv_r[~ok] = np.nan
    return StereoMatches(ok, uv_r, score)
