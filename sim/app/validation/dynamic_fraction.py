"""Fraction of tracked features that lie on moving objects, measured from the true segmentation.

The tracker is the VINS-Mono front-end of the ``vins`` estimator itself (:class:`vo.vins.feature_tracker.KltFrontend`,
seed 002 builds on it) with its defaults: Shi-Tomasi corners (at most 150, 30 px apart, quality 0.01) tracked
frame to frame by pyramidal KLT (21 x 21 window, 3 levels), lost tracks dropped, outliers of a
fundamental-matrix RANSAC (1 px) on undistorted points removed, and new corners only away from the tracked
ones, the longest-tracked claiming their area first. A feature is *dynamic* when the segmentation id under
its (rounded) pixel belongs to an actor that moves during the run (``segmentation_ids.csv``: ``moving`` = 1).
The fraction is counted over all feature observations of all frames (a feature tracked for 10 frames counts
10 times, as in a VINS window).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.vins.feature_tracker import KltFrontend, mask_at


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


def track_features(images, camera):
    """Yield ``(k, points (N, 2) float)``: the raw pixels of the features the ``vins`` front-end tracks in frame
    ``k`` of the grey ``images`` (uint8, taken by ``camera``, a :class:`rigs.model.Camera`)."""
    frontend = KltFrontend(camera)
    for k, img in enumerate(images):
        yield k, frontend.track(img, k).px


def dynamic_fraction(images, seg_ids, moving_ids, camera) -> DynamicFraction:
    """Track ``images`` (grey uint8 of ``camera``) and count features whose ``seg_ids[k]`` value (an (H, W) int
    map per frame, same size) is in ``moving_ids``."""
    moving = np.array(sorted(set(int(i) for i in moving_ids)), dtype=np.int64)
    n_feat = n_dyn = 0
    per = []
    for k, pts in track_features(images, camera):
        dyn = np.isin(mask_at(np.asarray(seg_ids[k]), pts), moving)
        n_feat += len(pts)
        n_dyn += int(dyn.sum())
        per.append(float(dyn.mean()) if len(pts) else 0.0)
    return DynamicFraction(len(per), n_feat, n_dyn, tuple(per))
