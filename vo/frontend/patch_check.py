"""Verification of LK matches by the zero-mean normalised cross-correlation (ZNCC) of their windows.

Our extension (not in seed 003). LK converging and passing the forward-backward check does not prove that
the two windows show the same texture: where a view's texture is below the camera's noise (a nearly blank
wall under the ``realistic`` camera's shot noise and auto exposure), the local-mean-normalised LK of
:mod:`vo.frontend.lk_normalized` started at zero flow stays within 1-2 px of its start in both directions
on windows of noise, so such corners become forward-backward-consistent *stationary* tracks while the view
turns by 20-45 px per frame (``indoor-realistic`` seed 0, frames 215-237: 16-49 of 46-184 tracks per frame;
docs/estimators.md, "Photometric robustness"). They outvote the few real tracks in PnP and give a turn
of 3 degrees per frame as 0.8 degrees.

The ZNCC of the window around ``p0`` in ``img0`` and around ``p1`` in ``img1`` (bilinear, ``win`` x ``win``
pixels) separates them: a window of signal variance ``s^2`` under independent noise of variance ``n^2`` in
each image has an expected ZNCC with its true match of ``s^2 / (s^2 + n^2)``, with a wrong one about 0
(a fixed-in-image component such as vignetting adds a little). A gate at 0.5 therefore keeps the matches
whose window texture is at least as strong as the image noise, whatever the rig, the image size or the
gain: it is dimensionless and invariant to an affine change of brightness (exposure, vignetting over the
window). Measured on the stationary noise tracks above: ZNCC 5th percentile 0.04-0.13, median 0.20-0.29 per
frame; the moving tracks of the same frames median 0.44-0.87.

A translation-only window also decorrelates where the view deforms across it: on the real KITTI turn the
road near the car (stereo disparities 35-58 px: a shear of ~0.3 px per row between the views; the ground's
expansion between frames) gives true matches ZNCC 0.2-0.5 although their windows' texture is 3-35 times the
noise. With ``affine`` the matches that fail the gate are given a second chance: the affine + gain/offset
Lucas-Kanade fit of their window (:func:`vo.frontend.affine_lk.refine_affine`, started at the LK match) and the
ZNCC of that warped window; the match is kept when that ZNCC reaches the gate and the fitted centre lies
within ``AFFINE_MAX_MOVE_PX`` of the LK match (the match itself is not moved). A window of noise stays
uncorrelated under any warp of 6 parameters over its ``win^2`` samples, a window across an occlusion too.
Measured: docs/estimators.md, "ZNCC check and disparity-offset tolerance".
"""
from __future__ import annotations

import cv2
import numpy as np

from vo.frontend.affine_lk import bilinear, refine_affine

AFFINE_MAX_MOVE_PX = 1.0    # the affine fit's centre this close to the LK match (the forward-backward gate)


def zncc(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, win: int) -> np.ndarray:
    """ZNCC (N,) in [-1, 1] of the ``win`` x ``win`` windows of grey images ``img0`` at ``p0`` (N,2) and
    ``img1`` at ``p1`` (N,2) (pixel coordinates, bilinear sampling, borders replicated); 0 for a window
    without variance."""
    p0 = np.asarray(p0, np.float64).reshape(-1, 2)
    p1 = np.asarray(p1, np.float64).reshape(-1, 2)
    if len(p0) == 0:
        return np.zeros(0)
    return _zncc_rows(_windows(img0, p0, win), _windows(img1, p1, win))


def _zncc_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """ZNCC (N,) of the rows of ``a`` and ``b`` (N, M) float64 (changed in place: zero mean); 0 for a row
    without variance."""
    a -= a.mean(axis=1, keepdims=True)
    b -= b.mean(axis=1, keepdims=True)
    den = np.sqrt(np.einsum("ij,ij->i", a, a) * np.einsum("ij,ij->i", b, b))
    num = np.einsum("ij,ij->i", a, b)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def _windows(img: np.ndarray, p: np.ndarray, win: int) -> np.ndarray:
    """(N, win*win) float64 samples of ``img`` on a ``win`` x ``win`` grid centred on each point of ``p``."""
    r = (np.arange(win, dtype=np.float32) - (win - 1) / 2.0)
    dx, dy = np.meshgrid(r, r)
    mx = (p[:, 0, None].astype(np.float32) + dx.ravel()[None, :]).astype(np.float32)
    my = (p[:, 1, None].astype(np.float32) + dy.ravel()[None, :]).astype(np.float32)
    out = cv2.remap(np.asarray(img, np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.astype(np.float64)


def affine_zncc(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, win: int) -> tuple:
    """ZNCC (N,) of the ``win`` x ``win`` windows of ``img0`` at ``p0`` (N,2) and of ``img1`` under the affine
    warp fitted from the match ``p1`` (N,2) (:func:`vo.frontend.affine_lk.refine_affine`), the fitted centres
    (N,2) and whether the fit converged (N,) (ZNCC -1 where not)."""
    p0 = np.asarray(p0, np.float64).reshape(-1, 2)
    c, A, ok = refine_affine(img0, img1, p0, np.asarray(p1, np.float64).reshape(-1, 2), win=win)
    r = np.arange(win, dtype=np.float64) - (win - 1) / 2.0
    offs = np.stack(np.meshgrid(r, r), axis=-1).reshape(-1, 2)
    a = bilinear(np.asarray(img0, np.float32), p0[:, None, :] + offs[None]).astype(np.float64)
    b = bilinear(np.asarray(img1, np.float32),
                 c[:, None, :] + offs[None] @ (np.eye(2)[None] + A).transpose(0, 2, 1)).astype(np.float64)
    return np.where(ok, _zncc_rows(a, b), -1.0), c, ok


def zncc_mask(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, ok: np.ndarray, win: int,
              min_zncc: float, affine: bool = False) -> np.ndarray:
    """``ok`` (N,) with the matches whose window ZNCC is below ``min_zncc`` removed (``min_zncc`` <= -1 or no
    match: ``ok`` unchanged); with ``affine`` such a match stays when its affine-warped window's ZNCC
    (:func:`affine_zncc`) reaches ``min_zncc`` and the fit's centre is within ``AFFINE_MAX_MOVE_PX`` of ``p1``
    (module docstring)."""
    ok = np.asarray(ok, bool).copy()
    if min_zncc <= -1.0 or not ok.any():
        return ok
    idx = np.flatnonzero(ok)
    p0s, p1s = np.asarray(p0, np.float64).reshape(-1, 2)[idx], np.asarray(p1, np.float64).reshape(-1, 2)[idx]
    bad = zncc(img0, img1, p0s, p1s, win) < min_zncc
    if affine and bad.any():
        z, c, fitted = affine_zncc(img0, img1, p0s[bad], p1s[bad], win)
        near = np.linalg.norm(c - p1s[bad], axis=1) <= AFFINE_MAX_MOVE_PX
        bad[bad] = ~(fitted & near & (z >= min_zncc))
    ok[idx[bad]] = False
    return ok
