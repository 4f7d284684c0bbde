"""Covariance of a translation-LK point caused by one image's noise (first order).

OpenCV's pyramidal LK (``calcOpticalFlowPyrLK``) converges, at full resolution, to the shift ``d`` with
``sum_w g_s(x) [I_B(x + d) - I_A(x)] = 0`` over the ``win x win`` window ``w`` about the template point,
``g_s`` the template's Scharr gradient (scale 1/32) sampled bilinearly at the sub-pixel window
positions, the intensities sampled bilinearly too. An i.i.d. noise ``n`` of std ``sigma`` in one of
the two images moves the solution by ``A^-1 sum_w g_s(x) n~(x)``, ``n~`` the bilinearly interpolated
noise and ``A = sum_w g_s grad(I)^T`` the sensitivity of the condition to ``d`` (``grad(I)`` the
central-difference gradient, closer than Scharr's smoothed one to the derivative of the
interpolated image). So one image's noise has the covariance (the point's *footprint*)

    ``C = sigma^2 A^-1 H A^-T``,   ``H = sum_y h(y) h(y)^T``,   ``h(y) = sum_x g_s(x) b(x, y)``,

``b(x, y)`` the bilinear weight of pixel ``y`` in the sample at ``x``; ``H = G = sum g_s g_s^T`` at
integer positions, smaller in between. An LK from image A to image B errs by ``a_B - a_A`` (each
image its own footprint at its own point, independent): ``C_A + C_B``. Checked against OpenCV's LK by
Monte Carlo in ``tests/test_frontend_lk_noise.py`` (predicted / measured std 0.95-1.0 on smooth
textures; OpenCV's error is smaller, down to 0.85x, on textures with 1-px detail, which the
central difference does not fully capture).
"""
from __future__ import annotations

import cv2
import numpy as np

from vo.errors import VoError
from vo.frontend.lk_invariant import central_gradients

def _gradients(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scharr (1/32) and central-difference gradients, each (H,W,2) float32 ``[d/dx, d/dy]``."""
    f = np.asarray(img, np.float32)
    g_s = np.stack([cv2.Scharr(f, cv2.CV_32F, 1, 0, scale=1 / 32), cv2.Scharr(f, cv2.CV_32F, 0, 1, scale=1 / 32)], -1)
    g_c = np.stack(central_gradients(f), -1)
    return g_s, g_c


def _bilinear(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Integer corners (N,2) and the weights (N,2,2) ``[dy, dx]`` of bilinear sampling at ``pts``."""
    i0 = np.floor(pts).astype(np.int64)
    fx, fy = (pts - i0).T
    w = np.stack([np.stack([(1 - fx) * (1 - fy), fx * (1 - fy)], -1), np.stack([(1 - fx) * fy, fx * fy], -1)], 1)
    return i0, w


def _windows(g: np.ndarray, i0: np.ndarray, win: int) -> np.ndarray:
    """(N, win+1, win+1, C) patches of ``g`` (H,W,C) from ``i0 - win//2`` (edge-padded)."""
    r, pad = win // 2, win // 2 + 2
    gp = np.pad(g, ((pad, pad), (pad, pad), (0, 0)), mode="edge")
    h, w = g.shape[:2]
    x = np.clip(i0[:, 0], 0, w - 1) - r + pad
    y = np.clip(i0[:, 1], 0, h - 1) - r + pad
    k = np.arange(win + 1)
    return gp[(y[:, None] + k)[:, :, None], (x[:, None] + k)[:, None, :]]


def _sampled(P: np.ndarray, w: np.ndarray, win: int) -> np.ndarray:
    """Bilinear samples (N,win,win,C) of the patches ``P`` with weights ``w`` (N,2,2)."""
    return sum(w[:, dy, dx, None, None, None] * P[:, dy:dy + win, dx:dx + win] for dy in (0, 1) for dx in (0, 1))


def lk_noise_cov(img: np.ndarray, pts: np.ndarray, win: int, sigma: float) -> np.ndarray:
    """(N,2,2) footprint covariance (px^2) of the points ``pts`` (N,2) in the (H,W) image ``img`` with
    i.i.d. noise ``sigma`` (grey levels) for an LK window ``win`` (odd); module docstring. Points
    with a singular window get an infinite covariance."""
    pts = np.asarray(pts, np.float64).reshape(-1, 2)
    if win < 3 or win % 2 != 1:
        raise VoError(f"lk_noise_cov.win: {win!r}; must be an odd integer >= 3")
    if not np.all(np.isfinite(pts)):
        raise VoError("lk_noise_cov.pts: non-finite point coordinates")
    if len(pts) == 0:
        return np.zeros((0, 2, 2))
    g_s, g_c = _gradients(img)
    i0, w = _bilinear(pts)
    gs = _sampled(_windows(g_s, i0, win), w, win).astype(np.float64)
    gc = _sampled(_windows(g_c, i0, win), w, win).astype(np.float64)
    h = np.zeros((len(pts), win + 1, win + 1, 2))
    for dy in (0, 1):
        for dx in (0, 1):
            h[:, dy:dy + win, dx:dx + win] += w[:, dy, dx, None, None, None] * gs
    H = np.einsum("nabi,nabj->nij", h, h)
    A = np.einsum("nabi,nabj->nij", gs, gc)
    out = np.full((len(pts), 2, 2), np.inf)
    ok = np.abs(np.linalg.det(A)) > 1e-9 * np.einsum("nii->n", A) ** 2
    Ai = np.linalg.inv(A[ok])
    out[ok] = float(sigma) ** 2 * Ai @ H[ok] @ np.swapaxes(Ai, 1, 2)
    return out
