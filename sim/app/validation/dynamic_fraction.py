"""Fraction of tracked features that lie on moving objects, measured from the true segmentation.

The tracker is VINS-Mono's front-end (the one seed 002 builds on), with OpenCV: Shi-Tomasi corners
(``goodFeaturesToTrack``, at most ``max_features`` = 150, ``min_distance`` = 30 px, quality 0.01, new
corners only away from tracked ones) tracked frame to frame by pyramidal KLT (21 x 21 window, 3 levels),
lost tracks dropped, and, as VINS-Mono does, outliers of a fundamental-matrix RANSAC (1 px) removed.
A feature is *dynamic* when the segmentation id under its (rounded) pixel belongs to an actor that moves
during the run (``segmentation_ids.csv``: ``moving`` = 1). The fraction is counted over all feature
observations of all frames (a feature tracked for 10 frames counts 10 times, as in a VINS window).
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.errors import SimError


@dataclass(frozen=True)
class FrontEndConfig:
    max_features: int = 150
    min_distance_px: int = 30
    quality: float = 0.01
    win_px: int = 21
    levels: int = 3
    f_ransac_px: float = 1.0          # 0 disables the fundamental-matrix rejection


@dataclass(frozen=True)
class DynamicFraction:
    """Counts over the sequence: ``n_features`` observations, ``n_dynamic`` of them on moving actors."""

    n_frames: int
    n_features: int
    n_dynamic: int
    per_frame: tuple              # (dynamic fraction per frame)

    @property
    def fraction(self) -> float:
        return self.n_dynamic / self.n_features if self.n_features else 0.0


def track_features(images, config: FrontEndConfig = FrontEndConfig()):
    """Yield ``(k, points (N, 2) float32)``: the features tracked in frame ``k`` of grey ``images``."""
    import cv2
    prev, pts = None, np.empty((0, 2), np.float32)
    for k, img in enumerate(images):
        if prev is not None and len(pts):
            nxt, st, _ = cv2.calcOpticalFlowPyrLK(prev, img, pts.reshape(-1, 1, 2), None,
                                                  winSize=(config.win_px, config.win_px), maxLevel=config.levels)
            h, w = img.shape[:2]
            nxt = nxt.reshape(-1, 2)
            ok = (st.ravel() == 1) & (nxt[:, 0] >= 0) & (nxt[:, 1] >= 0) & (nxt[:, 0] < w) & (nxt[:, 1] < h)
            old, pts = pts[ok], nxt[ok]
            if config.f_ransac_px > 0 and len(pts) >= 8:
                _, inl = cv2.findFundamentalMat(old, pts, cv2.FM_RANSAC, config.f_ransac_px, 0.99)
                if inl is not None:
                    pts = pts[inl.ravel() == 1]
        pts = _top_up(img, pts, config)
        yield k, pts
        prev = img


def _top_up(img, pts, config):
    """Add Shi-Tomasi corners at least ``min_distance`` from the tracked ones, up to ``max_features``."""
    import cv2
    need = config.max_features - len(pts)
    if need <= 0:
        return pts
    mask = np.full(img.shape[:2], 255, np.uint8)
    for x, y in pts:
        cv2.circle(mask, (int(round(x)), int(round(y))), config.min_distance_px, 0, -1)
    new = cv2.goodFeaturesToTrack(img, need, config.quality, config.min_distance_px, mask=mask)
    if new is None:
        return pts
    return np.vstack([pts, new.reshape(-1, 2).astype(np.float32)])


def dynamic_fraction(images, seg_ids, moving_ids, config: FrontEndConfig = FrontEndConfig()) -> DynamicFraction:
    """Track ``images`` (grey uint8) and count features whose ``seg_ids[k]`` value (an (H, W) int map per
    frame, same size) is in ``moving_ids``."""
    moving = np.array(sorted(set(int(i) for i in moving_ids)), dtype=np.int64)
    n_feat = n_dyn = 0
    per = []
    for k, pts in track_features(images, config):
        seg = np.asarray(seg_ids[k])
        u = np.clip(np.rint(pts[:, 0]).astype(int), 0, seg.shape[1] - 1)
        v = np.clip(np.rint(pts[:, 1]).astype(int), 0, seg.shape[0] - 1)
        dyn = np.isin(seg[v, u], moving)
        n_feat += len(pts)
        n_dyn += int(dyn.sum())
        per.append(float(dyn.mean()) if len(pts) else 0.0)
    return DynamicFraction(len(per), n_feat, n_dyn, tuple(per))


def read_moving_seg_ids(path) -> set:
    """Segmentation ids (as stored in the PNGs) of moving actors from a ``segmentation_ids.csv``."""
    path = Path(path)
    if not path.is_file():
        raise SimError(f"{path}: no segmentation_ids.csv (generate with --segmentation)")
    with path.open() as f:
        rows = list(csv.DictReader(f))
    if rows and not {"seg_id", "moving"} <= set(rows[0]):
        raise SimError(f"{path}: expected columns seg_id and moving, got {sorted(rows[0])}")
    return {int(r["seg_id"]) for r in rows if int(r["moving"]) == 1}


def dataset_dynamic_fraction(folder, config: FrontEndConfig = FrontEndConfig(), max_frames: int | None = None):
    """:func:`dynamic_fraction` of the left camera of a generated EuRoC folder written with ``--segmentation``."""
    import cv2
    folder = Path(folder)
    cam = folder / "mav0" / "cam0"
    seg_dir = cam / "segmentation"
    if not seg_dir.is_dir():
        raise SimError(f"{folder}: no mav0/cam0/segmentation (generate with --segmentation)")
    names = sorted(p.name for p in (cam / "data").glob("*.png"))[:max_frames]
    moving = read_moving_seg_ids(folder / "segmentation_ids.csv")
    images = (cv2.imread(str(cam / "data" / n), cv2.IMREAD_GRAYSCALE) for n in names)
    segs = [_read_seg(seg_dir / n) for n in names]
    return dynamic_fraction(images, segs, moving, config)


def _read_seg(path: Path) -> np.ndarray:
    import cv2
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise SimError(f"{path}: missing or unreadable segmentation image")
    return img.astype(np.int64)
