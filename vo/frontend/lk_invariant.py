"""Illumination-invariant pyramidal Lucas-Kanade (seed 003, section 5.2, Algorithm 1).

Residual per patch pixel ``x_i``: ``r_i(d) = I1(x_i + d) / mean(I1 patch) - I0(x_i) / mean(I0 patch)``,
so a gain change between the images (``I1 = g * I0``) leaves the residual unchanged.
Translation-only inverse-compositional Gauss-Newton on a Gaussian pyramid, vectorised over points.

Corrections to the garbled Algorithm 1 of seed 003 (implemented the correct form):
- line 10 ``point / pow(2, 1)`` -> ``point / 2**level`` (the point scaled to each pyramid level);
- line 18 "sum of hessian.inverse()" -> the inverse of the SUM of per-pixel ``g g^T``
  (Gauss-Newton normal matrix), with ``g`` the gradient of the mean-normalised source patch;
- lines 22-27 accumulate ``dmotion`` without resetting it each iteration; we compute a fresh
  increment ``delta = H^-1 sum g r`` every iteration and update ``d <- d - delta``
  (inverse-compositional update for a translation warp);
- the level loop (line 13) counts ``l`` down; the motion is doubled between levels (line 36),
  but not after the finest level.
"""
from __future__ import annotations

import cv2
import numpy as np


def _pyramid(img: np.ndarray, levels: int) -> list:
    pyr = [np.asarray(img, dtype=np.float32)]
    for _ in range(levels - 1):
        pyr.append(cv2.pyrDown(pyr[-1]))
    return pyr


def central_gradients(img: np.ndarray) -> tuple:
    """Central differences ``(I[x+1] - I[x-1]) / 2`` along u and v (float32 images)."""
    k = np.array([[-0.5, 0.0, 0.5]], dtype=np.float32)
    gx = cv2.filter2D(img, cv2.CV_32F, k, borderType=cv2.BORDER_REPLICATE)
    gy = cv2.filter2D(img, cv2.CV_32F, k.T, borderType=cv2.BORDER_REPLICATE)
    return gx, gy


def _sample(img: np.ndarray, centres: np.ndarray, offs: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``img`` at ``centres (N,2) + offs (P,2)`` -> (N,P) float32."""
    xy = centres[:, None, :] + offs[None, :, :]
    return cv2.remap(img, xy[..., 0].astype(np.float32), xy[..., 1].astype(np.float32),
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def lk_illumination_invariant(img0: np.ndarray, img1: np.ndarray, pts: np.ndarray, win: int = 21,
                              levels: int = 4, iters: int = 30, eps: float = 0.01) -> tuple:
    """Track ``pts`` (N,2) pixels of ``img0`` into ``img1``.

    ``levels`` counts pyramid levels including full resolution (OpenCV ``maxLevel = levels - 1``).
    Returns ``(p1 (N,2) float64, ok (N,) bool)``; ``ok`` is False for points that leave the image,
    have a singular normal matrix (no texture) or a non-positive patch mean.
    """
    p0 = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    n = p0.shape[0]
    if n == 0:
        return np.zeros((0, 2)), np.zeros(0, bool)
    h, w = img0.shape[:2]
    pyr0, pyr1 = _pyramid(img0, levels), _pyramid(img1, levels)
    r = (win - 1) / 2.0
    g = np.arange(win, dtype=np.float64) - r
    offs = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    d = np.zeros((n, 2))
    ok = np.ones(n, bool)
    for lvl in range(levels - 1, -1, -1):
        d, ok = _track_level(pyr0[lvl], pyr1[lvl], p0 / 2.0 ** lvl, d, ok, offs, iters, eps)
        if lvl > 0:
            d *= 2.0
    p1 = p0 + d
    ok &= (p1[:, 0] >= 0) & (p1[:, 1] >= 0) & (p1[:, 0] <= w - 1) & (p1[:, 1] <= h - 1)
    return p1, ok & np.all(np.isfinite(p1), axis=1)


def _track_level(I0, I1, c0, d, ok, offs, iters, eps):
    """One pyramid level: Gauss-Newton on the mean-normalised residual for every point."""
    gx, gy = central_gradients(I0)
    T = _sample(I0, c0, offs).astype(np.float64)
    m0 = T.mean(axis=1)
    good = ok & (m0 > 1e-6)
    m0 = np.where(good, m0, 1.0)
    T /= m0[:, None]
    G = np.stack([_sample(gx, c0, offs), _sample(gy, c0, offs)], axis=-1) / m0[:, None, None]  # (N,P,2)
    H = np.einsum("npi,npj->nij", G, G)
    det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] ** 2
    good &= det > 1e-12 * np.maximum(1.0, np.trace(H, axis1=1, axis2=2)) ** 2
    Hinv = np.linalg.inv(np.where(good[:, None, None], H, np.eye(2)))
    hh, ww = I1.shape[:2]
    active = good.copy()
    for _ in range(iters):
        if not active.any():
            break
        a = np.flatnonzero(active)
        W = _sample(I1, c0[a] + d[a], offs).astype(np.float64)
        m1 = W.mean(axis=1)
        pos = m1 > 1e-6
        res = W / np.where(pos, m1, 1.0)[:, None] - T[a]
        delta = np.einsum("nij,nj->ni", Hinv[a], np.einsum("npi,np->ni", G[a], res))
        d[a] -= delta
        c = c0[a] + d[a]
        inside = (c[:, 0] >= 0) & (c[:, 1] >= 0) & (c[:, 0] <= ww - 1) & (c[:, 1] <= hh - 1)
        bad = ~(pos & inside & np.all(np.isfinite(d[a]), axis=1))
        good[a[bad]] = False
        d[a[bad]] = 0.0
        active[a] = ~bad & (np.linalg.norm(delta, axis=1) >= eps)
    return d, good
