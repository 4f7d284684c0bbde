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

A window whose own texture is strong against the noise cannot sit on noise, and its ZNCC with a true match
falls below the gate only by geometry the translation-only window does not model: on the real KITTI turn the
road near the car (stereo disparities 35-58 px, a shear of ~0.3 px per row between the views; temporal
expansion of the ground) gives true matches ZNCC 0.2-0.5 while their windows' standard deviation is 3-35
times the noise. So the check applies only to windows whose standard deviation (grey levels, both images'
noise included) is below ``max_texture_snr`` times the image noise ``n`` (:func:`band_noise_sigma` of the
first image): at 2, a window whose signal variance ``s^2 < 3 n^2`` (true-match ZNCC expected below 0.75).
Measured (docs/estimators.md, "ZNCC check and disparity-offset tolerance"): the blank-wall noise tracks of
``indoor-realistic`` seed 0 have 1.07-1.49 times the noise (5th-95th percentile), the matches the check
dropped on the real turn 2.7-35.
"""
from __future__ import annotations

import cv2
import numpy as np

from vo.frontend.noise_level import estimate_noise_sigma

_NOISE_BAND_ROWS = 32       # rows of each band of :func:`band_noise_sigma`
_NOISE_BAND_STEP = 4        # one band in this many


def zncc(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, win: int) -> np.ndarray:
    """ZNCC (N,) in [-1, 1] of the ``win`` x ``win`` windows of grey images ``img0`` at ``p0`` (N,2) and
    ``img1`` at ``p1`` (N,2) (pixel coordinates, bilinear sampling, borders replicated); 0 for a window
    without variance."""
    p0 = np.asarray(p0, np.float64).reshape(-1, 2)
    p1 = np.asarray(p1, np.float64).reshape(-1, 2)
    if len(p0) == 0:
        return np.zeros(0)
    a = _windows(img0, p0, win)
    b = _windows(img1, p1, win)
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


def band_noise_sigma(img: np.ndarray) -> float:
    """Noise std (grey levels) of a (H,W) image by :func:`vo.frontend.noise_level.estimate_noise_sigma` on
    every 4th band of 32 full-resolution rows (a quarter of the cost; subsampling the pixels instead would
    double the texture's frequency and overestimate the noise: 1.29 for 0.74 on a real KITTI frame); the whole
    image when it has fewer than 2 bands."""
    img = np.asarray(img)
    h = img.shape[0]
    starts = range(0, h - _NOISE_BAND_ROWS + 1, _NOISE_BAND_ROWS * _NOISE_BAND_STEP)
    if len(starts) < 2:
        return estimate_noise_sigma(img)
    return float(np.mean([estimate_noise_sigma(img[a:a + _NOISE_BAND_ROWS]) for a in starts]))


def zncc_mask(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, ok: np.ndarray, win: int,
              min_zncc: float, max_texture_snr: float = 0.0) -> np.ndarray:
    """``ok`` (N,) with the matches whose window ZNCC is below ``min_zncc`` removed (``min_zncc`` <= -1 or no
    match: ``ok`` unchanged); with ``max_texture_snr`` > 0 only those whose ``img0`` window's standard
    deviation is below ``max_texture_snr`` times the noise of ``img0`` (:func:`band_noise_sigma`, computed only
    when a match fails the ZNCC gate) (module docstring)."""
    ok = np.asarray(ok, bool).copy()
    if min_zncc <= -1.0 or not ok.any():
        return ok
    idx = np.flatnonzero(ok)
    p0s, p1s = np.asarray(p0, np.float64).reshape(-1, 2)[idx], np.asarray(p1, np.float64).reshape(-1, 2)[idx]
    bad = zncc(img0, img1, p0s, p1s, win) < min_zncc
    if max_texture_snr > 0 and bad.any():
        sd = _windows(img0, p0s[bad], win).std(axis=1)
        bad[bad] = sd < max_texture_snr * band_noise_sigma(img0)
    ok[idx[bad]] = False
    return ok
