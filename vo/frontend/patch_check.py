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

With ``texture_snr`` > 0 (``rop``'s front-end, :mod:`vo.rop.tracks`) the gate applies only to the matches
whose weaker window has a standard deviation below ``texture_snr`` times the image's noise
(:class:`NoiseLevel`: Immerkaer's estimate of :func:`vo.frontend.noise_level.estimate_noise_sigma`): the
windows where a true match's expected ZNCC, ``s^2 / (s^2 + n^2)`` with ``s^2 = std^2 - n^2``, is below
``1 - 1 / texture_snr^2`` (0.75 at 2), i.e. where a low ZNCC can mean a match on noise. A window of texture
many times the noise that decorrelates was deformed (perspective, shear) or straddles an occlusion; its
position is then judged by the forward-backward, epipolar and RANSAC tests, not by its ZNCC. Measured on
whole `campus` routes (noise 1.07 grey levels): the matches the plain gate drops there have windows of 5-30
times the noise, and 92 % of the temporal ones lie within 0.5 px of their true epipolar line
(docs/estimators.md, "What the ZNCC check drops on whole campus routes").
"""
from __future__ import annotations

import functools

import cv2
import numpy as np

from vo.frontend.affine_lk import bilinear, refine_affine
from vo.frontend.noise_level import estimate_noise_sigma

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


def _row_std(centred: np.ndarray) -> np.ndarray:
    """(N,) ``x.std(axis=1)`` of windows ``x`` (N, M) from their zero-mean rows (as :func:`_zncc_rows` leaves
    them): NumPy's own steps after the mean's subtraction, so the same floats."""
    return np.sqrt(np.add.reduce(centred * centred, axis=1) / centred.shape[1])


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
    dx, dy = _offsets(win)
    mx = p[:, 0, None].astype(np.float32) + dx
    my = p[:, 1, None].astype(np.float32) + dy
    out = cv2.remap(np.asarray(img, np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.astype(np.float64)


@functools.lru_cache(maxsize=8)
def _offsets(win: int) -> tuple:
    """(1, win*win) float32 column and row offsets of a ``win`` x ``win`` window's samples from its centre."""
    r = (np.arange(win, dtype=np.float32) - (win - 1) / 2.0)
    dx, dy = np.meshgrid(r, r)
    return dx.ravel()[None, :], dy.ravel()[None, :]


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


class NoiseLevel:
    """Noise std (grey levels) of an image, :func:`estimate_noise_sigma` of the whole image, remembered for the
    last ``keep`` images (by identity: the caller passes the same array objects for the same frame). Computed
    only for images where a match fails the ZNCC gate; ~1 ms of CPU for a 720x480 8-bit image (the integer path
    of :func:`estimate_noise_sigma`). (An estimate from a quarter of the rows was within 5 % on `campus` and
    `indoor-realistic` but 0.01-0.7 against 0.46-1.25 grey levels on the real KITTI turn, whose flattest pixels
    there are clipped sky.)"""

    def __init__(self, keep: int = 3):
        self.keep, self._seen = keep, []          # [(image, sigma)], newest last

    def __call__(self, img: np.ndarray) -> float:
        for im, sigma in self._seen:
            if im is img:
                return sigma
        sigma = estimate_noise_sigma(img)
        self._seen = (self._seen + [(img, sigma)])[-self.keep:]
        return sigma


def weak_texture(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, win: int,
                 texture_snr: float, noise=estimate_noise_sigma) -> np.ndarray:
    """(N,) True where the weaker of the ``win`` x ``win`` windows of ``img0`` at ``p0`` (N,2) and ``img1`` at
    ``p1`` (N,2) has a standard deviation below ``texture_snr`` times its image's noise (``noise``: image ->
    std, grey levels)."""
    s0 = _windows(img0, p0, win).std(axis=1) / max(noise(img0), 1e-6)
    s1 = _windows(img1, p1, win).std(axis=1) / max(noise(img1), 1e-6)
    return np.minimum(s0, s1) < texture_snr


def zncc_mask(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, p1: np.ndarray, ok: np.ndarray, win: int,
              min_zncc: float, affine: bool = False, texture_snr: float = 0.0, noise=None) -> np.ndarray:
    """``ok`` (N,) with the matches whose window ZNCC is below ``min_zncc`` removed (``min_zncc`` <= -1 or no
    match: ``ok`` unchanged); with ``affine`` such a match stays when its affine-warped window's ZNCC
    (:func:`affine_zncc`) reaches ``min_zncc`` and the fit's centre is within ``AFFINE_MAX_MOVE_PX`` of ``p1``;
    with ``texture_snr`` > 0 only when its weaker window's texture is below ``texture_snr`` times the noise
    (:func:`weak_texture`; ``noise`` image -> std, default :func:`estimate_noise_sigma`) (module docstring)."""
    ok = np.asarray(ok, bool).copy()
    if min_zncc <= -1.0 or not ok.any():
        return ok
    idx = np.flatnonzero(ok)
    p0s, p1s = np.asarray(p0, np.float64).reshape(-1, 2)[idx], np.asarray(p1, np.float64).reshape(-1, 2)[idx]
    f0, f1 = np.asarray(img0, np.float32), np.asarray(img1, np.float32)     # converted once for both uses
    a, b = _windows(f0, p0s, win), _windows(f1, p1s, win)
    bad = _zncc_rows(a, b) < min_zncc                 # a, b now zero-mean: their rows' std as weak_texture's
    if texture_snr > 0 and bad.any():
        noise = noise or estimate_noise_sigma
        s0 = _row_std(a[bad]) / max(noise(img0), 1e-6)
        s1 = _row_std(b[bad]) / max(noise(img1), 1e-6)
        bad[bad] = np.minimum(s0, s1) < texture_snr
    if affine and bad.any():
        z, c, fitted = affine_zncc(img0, img1, p0s[bad], p1s[bad], win)
        near = np.linalg.norm(c - p1s[bad], axis=1) <= AFFINE_MAX_MOVE_PX
        bad[bad] = ~(fitted & near & (z >= min_zncc))
    ok[idx[bad]] = False
    return ok
