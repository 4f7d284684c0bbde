"""Segmentation labels of features (vins-oracle, dynamic-feature diagnostics) and the N < 10 rule's confusion."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from vo.errors import DatasetError, EstimatorError
from vo.vins.truth_segmentation import FeatureLabels, rule_confusion


class _SegDataset:
    """Reader-API stand-in: 2 frames of 8x10 segmentation; object 4 (seg_id 5) moves and covers columns 6..9."""

    def __init__(self, root, with_mask=True, has_seg=True):
        self.root, self.with_mask, self.has_seg = root, with_mask, has_seg

    def __len__(self):
        return 2

    def segmentation(self, k, cam=0):
        if not self.has_seg:
            raise DatasetError("segmentation was not recorded")
        ids = np.full((8, 10), -1, np.int32)
        ids[:, 6:] = 4
        ids[:, :2] = 0
        return ids, (ids == 4) if self.with_mask else None


def test_labels_from_dynamic_mask_and_from_id_table(tmp_path):
    px = np.array([[0.2, 1.0], [6.4, 3.0], [9.7, 7.6], [5.4, 2.0], [-3.0, 20.0]])   # last: clipped to (0, 7)
    expected = np.array([False, True, True, False, False])
    labels = FeatureLabels.of(_SegDataset(tmp_path))          # no id table: the dynamic mask
    assert np.array_equal(labels.dynamic(1, px), expected)
    (tmp_path / "segmentation_ids.csv").write_text(
        "seg_id,geom_name,actor_id,kind,moving\n1,static/ground,-1,static,0\n5,dyn/car0,0,car,1\n")
    no_mask = FeatureLabels.of(_SegDataset(tmp_path, with_mask=False))
    assert np.array_equal(no_mask.dynamic(0, px), expected)
    (tmp_path / "segmentation_ids.csv").write_text(                # the car stands still: not dynamic
        "seg_id,geom_name,actor_id,kind,moving\n1,static/ground,-1,static,0\n5,dyn/car0,0,car,0\n")
    assert not FeatureLabels.of(_SegDataset(tmp_path)).dynamic(0, px).any()


def test_no_segmentation_means_no_labels_and_oracle_refuses(tmp_path):
    assert FeatureLabels.of(_SegDataset(tmp_path, has_seg=False)) is None
    assert FeatureLabels.of(None) is None
    from rigs.presets import get_rig
    from vo.vins.estimator import VinsEstimator
    est = VinsEstimator(get_rig("cart27"), preset="oracle")
    with pytest.raises(EstimatorError, match="segmentation") as e:
        est.set_dataset(_SegDataset(tmp_path, has_seg=False))
    assert "\n" not in str(e.value)


def test_rule_confusion_counts():
    dynamic = np.array([True, True, False, False, False, True])
    count = np.array([3, 12, 9, 10, 40, 1])
    assert rule_confusion(dynamic, count) == {"n_static": 3, "n_dynamic": 3, "static_as_outlier": 1,
                                              "dynamic_as_inlier": 1}


def test_oracle_keeps_features_off_moving_objects_and_refills_the_static_scene(campus_short):
    """On a rendered dataset whose (faked) segmentation marks the right half of the image as moving, vins-oracle's
    back-end sees only left-half features, more of them than vins has there (its detector fills the left half),
    and the diagnostics count vins's right-half features as dynamic."""
    from vo.dataset.open import open_dataset
    from vo.vins.estimator import VinsEstimator
    ds = open_dataset(campus_short)
    w, h = ds.rig.cameras[0].width, ds.rig.cameras[0].height

    class Half:
        root = campus_short

        def __len__(self):
            return len(ds)

        def segmentation(self, k, cam=0):
            ids = np.zeros((h, w), np.int32)
            ids[:, w // 2:] = 1
            return ids, ids == 1

    last = {}
    for preset in ("base", "oracle"):
        est = VinsEstimator(ds.rig, preset=preset)
        est.set_imu(ds.imu)
        est.set_dataset(Half())
        for k in range(3):
            est.process(ds.frame(k))
        last[preset] = d = est.diagnostics[-1]
        if preset == "oracle":
            assert d["n_dynamic"] == 0 and d["n_static"] == len(d["counts"]) > 20
            assert np.all(d["px"][:, 0] < w // 2 - 0.5)
        else:
            right = d["dynamic"]
            assert 0 < right.sum() < len(right) and d["n_dynamic"] == right.sum()
    # the budget freed by the right half goes to the left half: more static features than vins keeps there
    assert last["oracle"]["n_static"] > last["base"]["n_static"]


def test_table_metrics_after_initialisation():
    """vo.vins.tables.after_init: init frames are skipped; a post-init estimate equal to the truth up to a constant
    frame offset (alignment at the first post-init pose) has zero RPE, drift and ATE; a 1 % scale error on a
    straight 30 m path gives 1 % end drift."""
    from types import SimpleNamespace

    from vo.vins.tables import after_init
    n = 60
    G = np.repeat(np.eye(4)[None], n, 0)
    G[:, 0, 3] = np.arange(n) * 0.5
    t = np.arange(n, dtype=np.int64) * 100_000_000
    off = np.eye(4)
    off[:3, 3] = [3.0, -1.0, 2.0]
    frames = [SimpleNamespace(T_o_c0=np.eye(4) if k < 10 else off @ G[k], status="init" if k < 10 else "ok")
              for k in range(n)]
    m = after_init(frames, G, t)
    assert m["init_frame"] == 10 and m["rpe10"][2] < 1e-12 and m["drift_pct"] < 1e-10 and m["ate_rmse"] < 1e-12
    scaled = [SimpleNamespace(T_o_c0=f.T_o_c0.copy(), status=f.status) for f in frames]
    for f in scaled[10:]:
        f.T_o_c0[0, 3] = 5.0 + (f.T_o_c0[0, 3] - 5.0) * 1.01
    m = after_init(scaled, G, t)
    assert abs(m["drift_pct"] - 1.0) < 1e-9 and abs(m["path_m"] - 24.5) < 1e-12
