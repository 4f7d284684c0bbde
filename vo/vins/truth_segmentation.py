"""True segmentation of the features (perfect moving-object detection) for ``vins-oracle`` and diagnostics.

A dataset written with ``--segmentation`` has, per frame of cam0, object ids and a dynamic mask
(``EurocDataset.segmentation(k)``) and ``segmentation_ids.csv`` (columns ``seg_id``, ..., ``moving``;
seg_id = object id + 1). A feature is *dynamic* when its pixel in that frame lies on an object whose
``moving`` flag is set (the dynamic mask, used only without the table, also marks actors that never move).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from vo.errors import DatasetError, EstimatorError
from vo.vins.feature_tracker import mask_at


class FeatureLabels:
    """``dynamic(k, px)`` -> (n,) bool: which raw-pixel positions ``px`` (n,2) of frame ``k`` are on moving objects;
    ``mask(k)`` -> (h,w) bool, the moving objects of frame ``k``."""

    def __init__(self, dataset):
        self.dataset = dataset
        self._moving_ids = None

    @classmethod
    def of(cls, dataset):
        """Labels of ``dataset``, or None when it has no segmentation (real recordings, datasets without it)."""
        if dataset is None or not callable(getattr(dataset, "segmentation", None)) or len(dataset) == 0:
            return None
        try:
            dataset.segmentation(0)
        except DatasetError:
            return None
        return cls(dataset)

    def mask(self, k: int) -> np.ndarray:
        """Moving objects of frame ``k``: ids whose ``moving`` flag is set in ``segmentation_ids.csv`` when the
        dataset has it (the dynamic mask also covers actors that stand still the whole run, e.g. all of them
        at ``dynamic_density`` 0), else the dynamic mask."""
        ids, dyn = self.dataset.segmentation(k)
        table = Path(getattr(self.dataset, "root", ".")) / "segmentation_ids.csv"
        if self._moving_ids is None and (table.is_file() or dyn is None):
            self._moving_ids = _moving_ids(table)
        if self._moving_ids is not None:
            return np.isin(ids, self._moving_ids)
        return np.asarray(dyn, bool)

    def dynamic(self, k: int, px: np.ndarray) -> np.ndarray:
        return mask_at(self.mask(k), px)


def _moving_ids(path: Path) -> np.ndarray:
    """Object ids (seg_id - 1) whose ``moving`` column is 1 in ``segmentation_ids.csv``."""
    if not path.is_file():
        raise EstimatorError(f"{path}: missing; the segmentation has no dynamic mask and no id table")
    rows = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    if "seg_id" not in rows.dtype.names or "moving" not in rows.dtype.names:
        raise EstimatorError(f"{path}: expected columns seg_id and moving, got {', '.join(rows.dtype.names)}")
    return np.atleast_1d(rows["seg_id"])[np.atleast_1d(rows["moving"]) != 0].astype(np.int32) - 1


def rule_confusion(dynamic: np.ndarray, count: np.ndarray, n_min: int = 10) -> dict:
    """Seed 002's evaluation rule (a feature is an outlier when N < ``n_min``) against the true labels:
    counts of static/dynamic features, static ones labelled outliers, dynamic ones labelled inliers."""
    dynamic, short = np.asarray(dynamic, bool), np.asarray(count) < n_min
    return {"n_static": int(np.sum(~dynamic)), "n_dynamic": int(np.sum(dynamic)),
            "static_as_outlier": int(np.sum(~dynamic & short)), "dynamic_as_inlier": int(np.sum(dynamic & ~short))}
