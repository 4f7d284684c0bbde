"""KLT four-view front-end for the ROP estimator: ONE feature set gives the points of images 1-4.

Images 1, 2 are the left/right images of the last keyframe epoch, 3, 4 those of the current
frame. On a keyframe, corners are detected in the empty cells of a grid (seed 003; each cell's
highest Shi-Tomasi score, :func:`vo.frontend.klt.detect_in_empty_cells` with ``peaks_only=False``)
and matched left -> right by LK (forward-backward + calibrated epipolar check): ``p1``, ``p2``. Every frame,
the tracks are followed frame to frame on the left images by LK with a forward-backward check
(``p3``; consecutive frames, so the flow stays small) and matched into the current right image by
LK seeded with the keyframe disparity ``p3 + (p2 - p1)``, again forward-backward and epipolar
checked (``p4``, valid where ``ok4``). The ROPs 1-3, 1-4, 2-3, 2-4 then all come from these tracks
with no further matching. When the current frame becomes a keyframe its ``(p3, p4)`` become the
new ``(p1, p2)`` (tracks without a valid ``p4`` are dropped) and new corners fill the empty cells.
Every track has an identity (``FourView.ids``, kept across keyframes), which the chain bootstrap
(:mod:`vo.rop.chain_bootstrap`) uses to resample a track the same way in every step it enters.
Right-image points are stored with the right camera's principal point corrected by
:attr:`KltFourView.right_shift_px` (``stored = measured - shift`` along x; 0 unless ``rop``'s online
disparity-offset estimate applies one, :mod:`vo.rop.offset`), so every triangulation and ROP reads the
corrected disparity; the images are always sampled at the measured positions.

``refine="affine"`` (not in seed 003; see :mod:`vo.frontend.affine_lk`): every LK result is then
refined by an affine window warp against the KEYFRAME template: ``p2`` from ``p1`` (stereo), ``p3``
from ``p1`` in the keyframe left image, ``p4`` from ``p2`` in the keyframe right image, each seeded
by the translation LK above and by the track's warp of the previous frame; the keyframe windows
(:class:`vo.frontend.affine_lk.AffineTemplate`) are computed once per keyframe. The positions are then
single measurements against the keyframe instead of a frame-to-frame chain, and without
translation LK's window-averaging bias on perspective ground (docs/studies/rop_consistency.md).

OpenCV's Python binding of ``calcOpticalFlowPyrLK`` does not accept pre-built pyramids (the
``buildOpticalFlowPyramid`` output is rejected as ``prevImg``); the pyramids are built once per image and
LK runs level by level on them (:mod:`vo.frontend.lk_normalized`, :mod:`vo.frontend.klt_pyramids`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from vo.errors import VoError
from vo.frontend.affine_lk import AffineTemplate, affine_template, refine_to
from vo.frontend.depth_edge import off_edge
from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig, TrackIds, detect_in_empty_cells, stereo_gate
from vo.frontend.klt_pyramids import LkPyramids, lk_raw
from vo.frontend.lk_normalized import lk_fb_pyramids, mirrored_start
from vo.frontend.patch_check import NoiseLevel, zncc_mask
from vo.rop.relative import normalized_points
from rigs.geometry.pinhole import to_normalized


@dataclass
class FourView:
    """Points of the current tracks in the four images: raw pixels ``p1..p4`` (N,2), normalized
    undistorted ``x1..x4`` (N,2); ``ok4`` (N,) where ``p4`` is valid (``p1..p3`` always are)."""

    p1: np.ndarray
    p2: np.ndarray
    p3: np.ndarray
    p4: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    x3: np.ndarray
    x4: np.ndarray
    ok4: np.ndarray
    A3: np.ndarray | None = None     # (N,2,2) affine window warps keyframe -> current (refine="affine")
    A4: np.ndarray | None = None
    tmpl3: AffineTemplate | None = None   # keyframe windows at p1 (left) / p2 (right), refine="affine"
    tmpl4: AffineTemplate | None = None
    ids: np.ndarray | None = None         # (N,) int64 track identities, kept across keyframes (chain bootstrap)

    def __len__(self) -> int:
        return len(self.p1)

    def subset(self, mask: np.ndarray) -> "FourView":
        """The tracks where ``mask`` (N,) is True (templates and warps included)."""
        m = np.asarray(mask, bool)
        return FourView(self.p1[m], self.p2[m], self.p3[m], self.p4[m], self.x1[m], self.x2[m], self.x3[m],
                        self.x4[m], self.ok4[m], None if self.A3 is None else self.A3[m],
                        None if self.A4 is None else self.A4[m], None if self.tmpl3 is None else self.tmpl3.subset(m),
                        None if self.tmpl4 is None else self.tmpl4.subset(m), None if self.ids is None else self.ids[m])

    def pair(self, p: str) -> tuple[np.ndarray, np.ndarray]:
        """Normalized matches ``(x_i, x_j)`` of pair ``"13" | "14" | "23" | "24"``."""
        x = {"1": self.x1, "2": self.x2, "3": self.x3, "4": self.x4}
        sel = self.ok4 if p[1] == "4" else np.ones(len(self), bool)
        return x[p[0]][sel], x[p[1]][sel]


def lk_fb(img0, img1, p0, config: KltConfig, guess=None, pyramid=None, texture_snr: float = 0.0,
          noise=None, mirror: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Pyramidal LK ``img0 -> img1`` (optionally seeded with ``guess``) and back (seeded with ``p0``, or with
    ``mirror`` at :func:`~vo.frontend.lk_normalized.mirrored_start`); ``ok``
    where both directions converge inside the image, the round trip ends < ``fb_threshold_px`` from
    ``p0`` and the two windows correlate (ZNCC >= ``config.min_zncc``, or the affine fit with ``config.zncc_affine``:
    :mod:`vo.frontend.patch_check`; with ``texture_snr`` > 0 only on windows whose texture is below
    ``texture_snr`` times the noise, ``noise`` image -> std). With
    ``config.normalize_box`` (the default) on the local-mean-normalised pyramids of
    :mod:`vo.frontend.lk_normalized` (seed 003's intensity-invariant residual; ``pyramid`` image -> pyramid,
    default ``config.pyramid``), else on the raw images (from their raw pyramids when ``pyramid`` is an
    :class:`~vo.frontend.klt_pyramids.LkPyramids`: the same LK from pyramids built once per image)."""
    n = len(p0)
    if n == 0:
        return np.zeros((0, 2)), np.zeros(0, bool)
    if config.box:
        pyramid = pyramid or config.pyramid
        p1, ok = lk_fb_pyramids(pyramid(img0), pyramid(img1), p0, config.win, config.lk_iters,
                                config.lk_eps, config.fb_threshold_px, guess, mirror)
        if config.raw_fallback and not ok.all():       # the lost points: brightness constancy on the raw images
            lost = np.flatnonzero(~ok)
            p1[lost], ok[lost] = lk_fb(img0, img1, p0[lost], replace(config, normalize_box=0, min_zncc=-1.0),
                                       None if guess is None else np.asarray(guess)[lost], pyramid, mirror=mirror)
        return p1, zncc_mask(img0, img1, p0, p1, ok, config.win, config.min_zncc, config.zncc_affine, texture_snr,
                             noise)
    a = np.ascontiguousarray(p0, np.float32).reshape(-1, 1, 2)
    raws = pyramid if isinstance(pyramid, LkPyramids) else None
    b, st = _lk_raw(img0, img1, a, guess, config, raws)
    back_start = mirrored_start(b, guess, p0) if mirror and guess is not None else a
    a2, st2 = _lk_raw(img1, img0, b, back_start, config, raws)
    p1 = b.reshape(-1, 2).astype(np.float64)
    h, w = img1.shape[:2]
    ok = (st.ravel() == 1) & (st2.ravel() == 1) & np.all(np.isfinite(p1), axis=1)
    ok &= (p1[:, 0] >= 0) & (p1[:, 1] >= 0) & (p1[:, 0] <= w - 1) & (p1[:, 1] <= h - 1)
    ok &= np.linalg.norm(a2.reshape(-1, 2) - p0, axis=1) < config.fb_threshold_px
    return p1, zncc_mask(img0, img1, p0, p1, ok, config.win, config.min_zncc, config.zncc_affine, texture_snr, noise)


def _lk_raw(img0, img1, pts, init, config: KltConfig, pyramids: LkPyramids | None = None) -> tuple:
    """:func:`~vo.frontend.klt_pyramids.lk_raw` with ``config``'s window, levels and criteria, from the raw
    pyramids of ``pyramids`` when given."""
    pyrs = None if pyramids is None else tuple(pyramids.raw(im, config.win, config.max_level) for im in (img0, img1))
    return lk_raw(img0, img1, pts, config.win, config.max_level, config.lk_iters, config.lk_eps, init, pyrs)


class KltFourView:
    """Keyframe-anchored KLT tracks (see the module docstring). ``timings`` dicts get ``detect``,
    ``track`` and ``stereo`` in ms. ``texture_snr``: the ZNCC check of every LK match applies only to windows
    whose texture is below that many times the image noise (0: to every window; :mod:`vo.frontend.patch_check`)."""

    REFINES = ("translation", "affine")

    def __init__(self, rig, config: KltConfig = KltConfig(), refine: str = "translation", texture_snr: float = 0.0):
        if refine not in self.REFINES:
            raise VoError(f"rop.klt_refine: {refine!r}; valid: {', '.join(self.REFINES)}")
        self.rig, self.config, self.refine = rig, config, refine
        self.texture_snr, self._noise = float(texture_snr), NoiseLevel()
        self._kf_imgs = None
        self.cams = rig.cameras[:2]
        cam = self.cams[0]
        self.grid = Grid(cam.width, cam.height, config.cell)
        self.view = None             # the current FourView
        self._prev_left = None
        self._ids = TrackIds()       # identities of new tracks
        self._pyramid = LkPyramids(config.levels, config.box)   # normalised and raw pyramids of the last images
        self.right_shift_px = 0.0    # principal-point correction of the stored right points (module docstring)

    def normalize(self, p, k):
        cam = self.cams[k]
        if not cam.has_distortion:
            return to_normalized(p, cam.K)
        return normalized_points(p, cam.K, cam.dist_coeffs)

    @property
    def _shift(self) -> np.ndarray:
        """(2,) stored minus measured right-image position (:attr:`right_shift_px` along x)."""
        return np.array([self.right_shift_px, 0.0])

    def _stereo(self, left, right, p_l, guess=None):
        """Right points of left points ``p_l`` (N,2) -> ``(p_r stored (N,2), ok (N,))``; ``guess`` stored too."""
        s = self._shift
        p_r, ok = lk_fb(left, right, p_l, self.config, None if guess is None else guess + s, self._pyramid,
                        self.texture_snr, self._noise)
        p_r = p_r - s
        if ok.any():
            ok[ok] &= stereo_gate(self.rig, p_l[ok], p_r[ok], self.config)
        return p_r, ok

    def keyframe(self, left, right, timings: dict, keep_tracks: bool = True) -> int:
        """Make this frame the keyframe: carry tracks with a valid ``p4`` (if ``keep_tracks``), detect
        corners in empty cells, stereo-match them. Returns the number of keyframe features."""
        t0 = cv2.getTickCount()
        v = self.view
        if keep_tracks and v is not None and len(v):
            p1, p2, x1, x2, ids = v.p3[v.ok4], v.p4[v.ok4], v.x3[v.ok4], v.x4[v.ok4], v.ids[v.ok4]
        else:
            p1 = p2 = x1 = x2 = np.zeros((0, 2))
            ids = np.zeros(0, np.int64)
        new = detect_in_empty_cells(left, self.grid, p1, self.config, peaks_only=False)
        t1 = cv2.getTickCount()
        new_r, ok = self._stereo(left, right, new)
        if ok.any():
            ok[ok] &= off_edge(left, right, new[ok], new_r[ok] + self._shift, self.config)
        if self.refine == "affine" and ok.any():
            new_r[ok], _, ok[ok] = self._refine_right(affine_template(left, new[ok], self.config.win), right,
                                                      new_r[ok], None, new[ok])
        new, new_r = new[ok], new_r[ok]
        p1, p2 = np.vstack([p1, new]), np.vstack([p2, new_r])
        x1, x2 = np.vstack([x1, self.normalize(new, 0)]), np.vstack([x2, self.normalize(new_r, 1)])
        ids = np.r_[ids, self._ids.take(len(new))]
        self.view = FourView(p1, p2, p1.copy(), p2.copy(), x1, x2, x1.copy(), x2.copy(), np.ones(len(p1), bool),
                             ids=ids)
        self._prev_left, self._kf_imgs = left, (left, right)
        f = 1e3 / cv2.getTickFrequency()
        timings["detect"] = timings.get("detect", 0.0) + (t1 - t0) * f
        timings["stereo"] = timings.get("stereo", 0.0) + (cv2.getTickCount() - t1) * f
        return len(p1)

    def track(self, left, right, timings: dict, predict=None) -> FourView:
        """Track the keyframe features into the current stereo frame -> the current :class:`FourView`. ``predict``
        (indices (M,) -> predicted left pixels (M,2) of those tracks, :mod:`vo.rop.track_start`): a track the
        zero-flow search loses is searched again from its prediction (its backward check from the prediction
        mirrored, :func:`lk_fb`) when that lies beyond the zero-flow search's reach (:attr:`KltConfig.reach_px`)."""
        v = self.view
        t0 = cv2.getTickCount()
        p3, ok = lk_fb(self._prev_left, left, v.p3, self.config, pyramid=self._pyramid,
                       texture_snr=self.texture_snr, noise=self._noise)
        if predict is not None and not ok.all():
            lost = np.flatnonzero(~ok)
            guess = predict(lost)
            far = np.linalg.norm(guess - v.p3[lost], axis=1) > self.config.reach_px
            r = lost[far]
            p3[r], ok[r] = lk_fb(self._prev_left, left, v.p3[r], self.config, guess[far], self._pyramid,
                                 self.texture_snr, self._noise, mirror=True)
        A3, A4 = self._warps(v)
        t3, t4 = self._templates(v)
        if t3 is not None and ok.any():
            p3[ok], A3[ok], ok[ok] = refine_to(t3.subset(ok), left, p3[ok], A3[ok])
        v = FourView(v.p1[ok], v.p2[ok], p3[ok], v.p4[ok], v.x1[ok], v.x2[ok], v.x3[ok], v.x4[ok], v.ok4[ok],
                     A3[ok], A4[ok], None if t3 is None else t3.subset(ok), None if t4 is None else t4.subset(ok),
                     v.ids[ok])
        t1 = cv2.getTickCount()
        v.p4, v.ok4 = self._stereo(left, right, v.p3, guess=v.p3 + (v.p2 - v.p1))
        if self.refine == "affine" and v.ok4.any():
            k = np.flatnonzero(v.ok4)
            v.p4[k], v.A4[k], v.ok4[k] = self._refine_right(v.tmpl4.subset(k), right, v.p4[k], v.A4[k], v.p3[k])
        v.x3 = self.normalize(v.p3, 0)
        v.x4 = np.zeros_like(v.p4)
        v.x4[v.ok4] = self.normalize(v.p4[v.ok4], 1)
        self.view, self._prev_left = v, left
        f = 1e3 / cv2.getTickFrequency()
        timings["track"] = timings.get("track", 0.0) + (t1 - t0) * f
        timings["stereo"] = timings.get("stereo", 0.0) + (cv2.getTickCount() - t1) * f
        return v

    def _refine_right(self, template: AffineTemplate, right, p_right, A, p_left) -> tuple:
        """Affine refinement of right-image points ``p_right`` against ``template``, then the calibrated
        epipolar check against the left points ``p_left`` -> ``(p_right, A, ok)``."""
        p_right, A, ok = refine_to(template, right, p_right + self._shift, A)
        p_right = p_right - self._shift
        return p_right, A, ok & stereo_gate(self.rig, p_left, p_right, self.config)

    def _templates(self, v: FourView) -> tuple:
        """The keyframe windows of the tracks (``refine="affine"``; else ``(None, None)``): built once per
        keyframe, at the first :meth:`track` after it, then carried and subset with the tracks."""
        if self.refine != "affine":
            return None, None
        if v.tmpl3 is None:
            win = self.config.win
            v.tmpl3 = affine_template(self._kf_imgs[0], v.p1, win)
            v.tmpl4 = affine_template(self._kf_imgs[1], v.p2 + self._shift, win)
        return v.tmpl3, v.tmpl4

    @staticmethod
    def _warps(v: FourView) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the tracks' affine warps (zero = translation) for :meth:`track`."""
        n = len(v)
        return (np.zeros((n, 2, 2)) if v.A3 is None else v.A3.copy(),
                np.zeros((n, 2, 2)) if v.A4 is None else v.A4.copy())

    @property
    def empty_fraction(self) -> float:
        return self.grid.empty_fraction(self.view.p3) if self.view is not None else 1.0
