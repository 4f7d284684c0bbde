"""Affine Lucas-Kanade refinement of point tracks (Shi & Tomasi 1994, "Good features to track").

Translation-only LK (OpenCV's pyramidal LK, seed 003) returns, to first order, the flow averaged
over its window with the image-gradient energy as weight. Where the flow varies across the window
(ground seen in perspective: points lower in the image move faster, and the far, compressed part of
the window carries more gradient energy) that average is not the flow at the window centre: on the
textured ground of our scenes it under-estimates the flow by ~0.7 % at a 21 px window (measured in
docs/consistency.md, "KLT on perspective ground"). Chained frame to frame, that bias accumulates.

This module refines a track by fitting an affine warp of the window (2 translation + 4 linear
parameters) plus a photometric gain and offset, so the estimate is the motion of the window
*centre*:

    I1(c + (I + A) g) ~= lam * T(g) + beta,      T(g) = I0(p0 + g),  g in the win x win grid.

Solved by simultaneous inverse-compositional Gauss-Newton (Baker & Matthews, "Lucas-Kanade 20 years
on", part 1 sec. 3.2 and part 3): the geometric Jacobian is the template's steepest-descent images,
the appearance parameters enter additively, so the normal matrix is computed once per point. All
points are refined together (vectorised); images are sampled by bilinear interpolation at the exact
float64 positions (OpenCV's ``remap`` quantises sub-pixel positions to 1/32 px), in float32 for 8-bit
images; the 8x8 normal matrices are formed and inverted in float64.

Shapes: ``p0, p1`` (N,2) pixels (u, v); ``A`` (N,2,2); ``ok`` (N,) bool.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.frontend.lk_invariant import central_gradients

MAX_SHIFT_PX = 2.0        # refinement may move a point at most this far from its LK estimate
MAX_LINEAR = 0.5          # |entries of A| bound (the window's scale/shear change), beyond = lost


def bilinear(img: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``img`` (H,W) at ``xy`` (...,2) float64 pixel positions (u, v), clamped to the
    image (edge replication). Float64 images are sampled in float64 (exact to round-off); others in
    float32 (weights and values: ~1e-7 relative, < 1e-4 grey levels on 8-bit images)."""
    h, w = img.shape[:2]
    dtype = np.float64 if img.dtype == np.float64 else np.float32
    x = np.clip(xy[..., 0], 0.0, w - 1.000001)
    y = np.clip(xy[..., 1], 0.0, h - 1.000001)
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0).astype(dtype), (y - y0).astype(dtype)
    flat = np.asarray(img, dtype=dtype).ravel()
    i = y0.astype(np.intp) * w + x0.astype(np.intp)
    a, b = flat[i], flat[i + 1]
    top = a + (b - a) * fx
    a, b = flat[i + w], flat[i + w + 1]
    return top + (a + (b - a) * fx - top) * fy


def _grid(win: int) -> np.ndarray:
    r = (win - 1) / 2.0
    g = np.arange(win, dtype=np.float64) - r
    return np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)          # (P,2) offsets (u, v)


@dataclass(frozen=True)
class AffineTemplate:
    """The template side of :func:`refine_affine` for points ``p0`` (N,2) of one image, computed once
    and reused while the template image stays the same (e.g. a keyframe): values ``T`` (N,P),
    transposed steepest-descent images ``Jt`` (N,8,P) of ``(c_u, c_v, a11, a12, a21, a22, lam, beta)``,
    inverse normal matrices ``Hinv`` (N,8,8), ``ok`` (N,) where the normal matrix is regular and the
    window lies inside the image, and the window size ``win``."""

    p0: np.ndarray
    T: np.ndarray
    Jt: np.ndarray
    Hinv: np.ndarray
    ok: np.ndarray
    win: int

    def __len__(self) -> int:
        return len(self.p0)

    def subset(self, index) -> "AffineTemplate":
        """The template of the points ``index`` (bool mask or integer indices)."""
        return AffineTemplate(self.p0[index], self.T[index], self.Jt[index], self.Hinv[index], self.ok[index],
                              self.win)

    def concat(self, other: "AffineTemplate") -> "AffineTemplate":
        """These points followed by ``other``'s (same ``win``)."""
        return AffineTemplate(*(np.concatenate([getattr(self, f), getattr(other, f)]) for f in _ARRAYS), self.win)

    def replaced(self, index, other: "AffineTemplate") -> "AffineTemplate":
        """A copy whose points ``index`` (integer indices) are ``other``'s points, in order (same ``win``)."""
        parts = []
        for f in _ARRAYS:
            v = getattr(self, f).copy()
            v[index] = getattr(other, f)
            parts.append(v)
        return AffineTemplate(*parts, self.win)


_ARRAYS = ("p0", "T", "Jt", "Hinv", "ok")


def affine_template(img0: np.ndarray, p0: np.ndarray, win: int = 21) -> AffineTemplate:
    """:class:`AffineTemplate` of the ``win`` x ``win`` windows of ``img0`` at ``p0`` (N,2)."""
    p0 = np.asarray(p0, np.float64).reshape(-1, 2)
    offs = _grid(win)
    f0 = np.asarray(img0, np.float32)
    gx, gy = central_gradients(f0)
    xy = p0[:, None, :] + offs[None]
    T, Ix, Iy = bilinear(f0, xy), bilinear(gx, xy), bilinear(gy, xy)
    u, v = offs[None, :, 0].astype(T.dtype), offs[None, :, 1].astype(T.dtype)
    J = np.stack([Ix, Iy, Ix * u, Ix * v, Iy * u, Iy * v, T, np.ones_like(T)], axis=-1)
    Jt = np.ascontiguousarray(J.transpose(0, 2, 1))                       # (N,8,P)
    H = Jt.astype(np.float64) @ J.astype(np.float64)
    cond = np.linalg.cond(H) if len(p0) else np.zeros(0)
    ok = np.isfinite(cond) & (cond < 1e12)
    Hinv = np.linalg.inv(np.where(ok[:, None, None], H, np.eye(8)))
    h0, w0 = f0.shape[:2]
    r = (win - 1) / 2.0
    ok &= (p0[:, 0] >= r) & (p0[:, 1] >= r) & (p0[:, 0] <= w0 - 1 - r) & (p0[:, 1] <= h0 - 1 - r)
    return AffineTemplate(p0, T, Jt, Hinv, ok, int(win))


def refine_affine(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray,
                  A: np.ndarray | None = None, win: int = 21, iters: int = 15,
                  eps: float = 1e-3) -> tuple:
    """Refine the matches ``p0`` (in ``img0``) -> ``p1`` (in ``img1``) with an affine window warp.

    ``A`` (N,2,2) is the initial linear part of the warp (zero = translation only); ``p1`` the initial
    translation (e.g. pyramidal LK's result). Iterates until the centre moves < ``eps`` px.
    Returns ``(p1 (N,2), A (N,2,2), ok (N,))``; ``ok`` is False where the normal matrix is singular,
    the refinement diverges (moves > ``MAX_SHIFT_PX`` or ``|A| > MAX_LINEAR``) or the warped window is
    not wholly inside ``img1`` (or the template window not inside ``img0``). Same as
    :func:`refine_to` with ``affine_template(img0, p0, win)``.
    """
    return refine_to(affine_template(img0, p0, win), img1, p1, A, iters, eps)


def refine_to(template: AffineTemplate, img1: np.ndarray, p1: np.ndarray, A: np.ndarray | None = None,
              iters: int = 15, eps: float = 1e-3) -> tuple:
    """:func:`refine_affine` with a precomputed :class:`AffineTemplate` (its ``win``)."""
    c = np.array(p1, np.float64).reshape(-1, 2)
    n = len(c)
    A = np.zeros((n, 2, 2)) if A is None else np.array(A, np.float64).reshape(n, 2, 2)
    if n == 0:
        return c, A, np.zeros(0, bool)
    T, Jt, Hinv, win = template.T, template.Jt, template.Hinv, template.win
    offs = _grid(win)
    ok = template.ok.copy()
    lam, beta = np.ones(n), np.zeros(n)
    f1 = np.asarray(img1, np.float32) if np.asarray(img1).dtype != np.float64 else np.asarray(img1)
    start = c.copy()
    active = ok.copy()
    for _ in range(iters):
        a = np.flatnonzero(active)
        if len(a) == 0:
            break
        M = np.eye(2)[None] + A[a]                                        # (n,2,2)
        xy = c[a, None, :] + offs[None] @ M.transpose(0, 2, 1)
        r = (bilinear(f1, xy) - lam[a, None] * T[a] - beta[a, None]).astype(Jt.dtype)
        d = (Hinv[a] @ (Jt[a] @ r[..., None]).astype(np.float64))[..., 0]
        # inverse composition of the geometric increment: W <- W o W(d)^-1
        Md = np.eye(2)[None] + d[:, 2:6].reshape(-1, 2, 2)
        M_new = M @ np.linalg.inv(Md)
        step = (M_new @ d[:, :2, None])[..., 0]
        c[a] = c[a] - step
        A[a] = M_new - np.eye(2)[None]
        lam[a] += d[:, 6]                                                 # appearance: additive
        beta[a] += d[:, 7]
        active[a] = np.linalg.norm(step, axis=1) >= eps
    h, w = np.asarray(img1).shape[:2]
    ok &= np.all(np.isfinite(c), axis=1) & np.all(np.isfinite(A.reshape(n, 4)), axis=1)
    ok &= np.linalg.norm(c - start, axis=1) <= MAX_SHIFT_PX
    ok &= np.all(np.abs(A.reshape(n, 4)) <= MAX_LINEAR, axis=1)
    corners = c[:, None, :] + _grid(2) * (win - 1) @ (np.eye(2)[None] + A).transpose(0, 2, 1)  # (N,4,2)
    ok &= np.all((corners >= 0) & (corners <= np.array([w - 1, h - 1])), axis=(1, 2))   # whole window inside
    return c, A, ok
