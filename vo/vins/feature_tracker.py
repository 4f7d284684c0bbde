"""VINS-Mono style monocular front-end (seed 002 §3.3): Shi-Tomasi corners tracked by pyramidal KLT,
F-matrix RANSAC outlier rejection on undistorted points, new corners outside a minimum-distance mask around
the tracked ones (longest-tracked first), and the number of times each feature was tracked (N, eq. 26).

``refine="affine"`` (not in seed 002 / VINS-Mono; :mod:`vo.frontend.affine_lk`): each KLT result is refined by
an affine window warp against the track's FIRST image (its template is kept, the warp carried from frame to
frame), so a track's position no longer accumulates the frame-to-frame bias of translation-only LK where the
flow varies across the window (road and roadside at car speed). Where the refinement fails (the window scaled
or sheared beyond the bounds of :func:`vo.frontend.affine_lk.refine_to`, more than 2 px from the KLT result,
or leaving the image) the KLT position stands and the track is re-anchored on the current image.

``track(img, t_ns, exclude)`` also takes a mask of pixels where no feature may live (``vins-oracle``: the
moving objects of the true segmentation). Features tracked into it are dropped and no corner is detected in
it, so the feature budget goes to the rest of the image, as a detect-and-remove front-end does.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vo.frontend.affine_lk import affine_template, refine_to

REFINES = ("none", "affine")
WIN = 21                 # LK window (VINS-Mono: 21x21)


@dataclass(frozen=True)
class FeatureFrame:
    """Features of one image: ``ids`` (n,) int64, ``px`` (n,2) raw pixels, ``xy`` (n,2) undistorted
    normalized coordinates (z = 1 plane of the camera), ``count`` (n,) times tracked N (1 = new)."""

    t_ns: int
    ids: np.ndarray
    px: np.ndarray
    xy: np.ndarray
    count: np.ndarray

    @property
    def id_set(self) -> frozenset:
        s = self.__dict__.get("_id_set")
        if s is None:
            s = frozenset(int(i) for i in self.ids)
            object.__setattr__(self, "_id_set", s)
        return s


class KltFrontend:
    """``track(img, t_ns)`` -> :class:`FeatureFrame`. ``camera``: :class:`rigs.model.Camera` (left)."""

    def __init__(self, camera, max_features: int = 150, min_distance_px: int = 30, f_threshold_px: float = 1.0,
                 refine: str = "none"):
        if refine not in REFINES:
            raise ValueError(f"KltFrontend: refine {refine!r}, expected one of {', '.join(REFINES)}")
        self.K, self.dist = camera.K, camera.dist_coeffs
        self.size = (camera.width, camera.height)
        self.max_features, self.min_dist, self.f_thr = max_features, int(min_distance_px), f_threshold_px
        self.refine = refine
        self.prev_img = None
        self.px = np.zeros((0, 2), np.float32)
        self.ids = np.zeros(0, np.int64)
        self.count = np.zeros(0, np.int64)
        self.tmpl = affine_template(np.zeros((WIN, WIN), np.uint8), np.zeros((0, 2)), WIN)  # refine="affine"
        self.A = np.zeros((0, 2, 2))
        self.next_id = 0

    def undistort(self, px: np.ndarray) -> np.ndarray:
        """Raw pixels (n,2) -> normalized undistorted coordinates (n,2)."""
        if len(px) == 0:
            return np.zeros((0, 2))
        return cv2.undistortPoints(px.reshape(-1, 1, 2).astype(np.float64), self.K, self.dist).reshape(-1, 2)

    def track(self, img: np.ndarray, t_ns: int, exclude: np.ndarray | None = None) -> FeatureFrame:
        """Track into ``img`` (h,w) uint8 and top up with new corners. ``exclude``: (h,w) bool, True where
        features must not lie (dropped when tracked there, never detected there), or None."""
        if exclude is not None and np.shape(exclude) != (self.size[1], self.size[0]):
            raise ValueError(f"KltFrontend.track: exclude mask shape {np.shape(exclude)}, "
                             f"expected {(self.size[1], self.size[0])}")
        if self.prev_img is not None and len(self.px):
            self._track_klt(img)
        if exclude is not None and len(self.px):
            self._keep(~mask_at(exclude, self.px))
        self.count = self.count + 1
        self._detect(img, exclude)
        self.prev_img = img
        return FeatureFrame(int(t_ns), self.ids.copy(), self.px.astype(float), self.undistort(self.px),
                            self.count.copy())

    def _keep(self, mask: np.ndarray) -> None:
        self.px, self.ids, self.count = self.px[mask], self.ids[mask], self.count[mask]
        if self.refine == "affine":
            self.tmpl, self.A = self.tmpl.subset(mask), self.A[mask]

    def _flow(self, img: np.ndarray) -> tuple:
        """Pyramidal KLT of the current features into ``img`` -> ``(p1 (n,2), ok (n,))``, inside the image."""
        p1, st, _ = cv2.calcOpticalFlowPyrLK(self.prev_img, img, self.px.reshape(-1, 1, 2), None,
                                             winSize=(WIN, WIN), maxLevel=3)
        p1 = p1.reshape(-1, 2)
        w, h = self.size
        return p1, (st.ravel() == 1) & (p1[:, 0] >= 1) & (p1[:, 1] >= 1) & (p1[:, 0] < w - 1) & (p1[:, 1] < h - 1)

    def _track_klt(self, img: np.ndarray) -> None:
        p1, ok = self._flow(img)
        if self.refine == "affine" and ok.any():
            self._refine(img, p1, np.flatnonzero(ok))
        p0 = self.px
        self.px = p1
        self._keep(ok)
        p0 = p0[ok]
        if len(p0) >= 8:                     # F-matrix RANSAC on undistorted points, threshold in pixels
            f = float(self.K[0, 0])
            u0, u1 = self.undistort(p0) * f, self.undistort(self.px) * f
            _, inl = cv2.findFundamentalMat(u0, u1, cv2.FM_RANSAC, self.f_thr, 0.99)
            if inl is not None:
                self._keep(inl.ravel() == 1)

    def _refine(self, img: np.ndarray, p1: np.ndarray, idx: np.ndarray) -> None:
        """Affine refinement of the KLT results ``p1[idx]`` against each track's template (in place). Where it
        fails the KLT position stands and the track is re-anchored: new template there, warp reset."""
        c, A, ok_r = refine_to(self.tmpl.subset(idx), img, p1[idx], self.A[idx])
        good, bad = idx[ok_r], idx[~ok_r]
        p1[good], self.A[good] = c[ok_r].astype(p1.dtype), A[ok_r]
        if len(bad):
            self.tmpl = self.tmpl.replaced(bad, affine_template(img, p1[bad], WIN))
            self.A[bad] = 0.0

    def _detect(self, img: np.ndarray, exclude: np.ndarray | None = None) -> None:
        order = np.argsort(-self.count, kind="stable")           # longest tracks claim their area first
        self._keep(order)
        w, h = self.size
        mask = np.full((h, w), 255, np.uint8)
        keep = np.zeros(len(self.px), bool)
        for k, (x, y) in enumerate(self.px):
            if mask[int(y), int(x)]:
                keep[k] = True
                cv2.circle(mask, (int(x), int(y)), self.min_dist, 0, -1)
        self._keep(keep)
        if exclude is not None:
            mask[exclude] = 0
        n_new = self.max_features - len(self.px)
        if n_new <= 0:
            return
        pts = cv2.goodFeaturesToTrack(img, n_new, 0.01, self.min_dist, mask=mask)
        if pts is None:
            return
        pts = pts.reshape(-1, 2).astype(np.float32)
        if self.refine == "affine":
            self.tmpl = self.tmpl.concat(affine_template(img, pts, WIN))
            self.A = np.concatenate([self.A, np.zeros((len(pts), 2, 2))])
        self.px = np.vstack([self.px, pts])
        self.ids = np.concatenate([self.ids, np.arange(self.next_id, self.next_id + len(pts), dtype=np.int64)])
        self.count = np.concatenate([self.count, np.ones(len(pts), np.int64)])
        self.next_id += len(pts)


def mask_at(mask: np.ndarray, px: np.ndarray) -> np.ndarray:
    """(n,) values of the (h,w) ``mask`` at the pixels nearest ``px`` (n,2) raw pixels (clamped to the image)."""
    h, w = mask.shape
    px = np.asarray(px, float).reshape(-1, 2)
    u = np.clip(np.rint(px[:, 0]).astype(int), 0, w - 1)
    v = np.clip(np.rint(px[:, 1]).astype(int), 0, h - 1)
    return mask[v, u]


def parallax_px(a: FeatureFrame, b: FeatureFrame, virtual_focal: float) -> tuple:
    """(mean displacement of common features in normalized coordinates * ``virtual_focal``, n common)."""
    common, ia, ib = np.intersect1d(a.ids, b.ids, assume_unique=True, return_indices=True)
    if len(common) == 0:
        return 0.0, 0
    return float(np.linalg.norm(a.xy[ia] - b.xy[ib], axis=1).mean() * virtual_focal), len(common)


def is_keyframe(feats: FeatureFrame, last_kf, min_parallax_px: float, min_tracked: int, virtual_focal: float,
                max_interval_s: float = float("inf")) -> bool:
    """Whether ``feats`` is a keyframe after ``last_kf`` (a FeatureFrame, or None: the first one is). Seed 002's two
    criteria (VINS-Mono): mean parallax to ``last_kf`` >= ``min_parallax_px`` (at ``virtual_focal``) or fewer than
    ``min_tracked`` tracked features. And, beyond seed 002 (ORB-SLAM3's inertial keyframes take one every 0.5 s):
    ``max_interval_s`` or more after ``last_kf``; the estimator uses it in the window only. Without it a vehicle
    standing still takes no keyframe (no parallax, the tracks kept), so that one IMU factor spans the whole stop;
    on urban-dynamic seed 4 (a 10.4 s interval, docs/vins.md) the window then jumped 6.3 m in the frame
    after the first keyframe after the stop."""
    if last_kf is None or (feats.t_ns - last_kf.t_ns) * 1e-9 >= max_interval_s:
        return True
    par, _ = parallax_px(feats, last_kf, virtual_focal)
    return par >= min_parallax_px or int(np.sum(feats.count > 1)) < min_tracked
