"""``rop``'s online disparity-offset estimate (:mod:`vo.rop.offset`) on rendered campus (6 s, cart27).

A written calibration whose right principal point is ``delta`` px below the images' is made by handing the
estimator the dataset's rig with ``cx`` of the right camera lowered: the images, and so every measured disparity,
are those of the true rig, which the estimator does not know (as in ``calib_error.stereo_disparity_px``)."""
from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest

from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.rop.estimator import RopEstimator
from vo.rop.tracks import KltFourView

from test_estimators_pnp import make_rig  # noqa: E402  (tests/ is on sys.path under pytest's rootdir)

pytestmark = pytest.mark.slow


def _written(rig, delta_px: float):
    """``rig`` with the right camera's ``cx`` ``delta_px`` lower: every disparity then reads ``delta_px`` short."""
    right = replace(rig.cameras[1], cx=rig.cameras[1].cx - delta_px)
    return replace(rig, cameras=(rig.cameras[0], right, *rig.cameras[2:]))


def _run(ds, rig, **options):
    est = RopEstimator(rig, **options)
    poses = np.array([est.process(f).T_o_c0 for f in ds.frames()])
    return est, poses


@pytest.fixture(scope="module")
def consistent(campus_short):
    ds = open_dataset(campus_short)
    return ds, _run(ds, ds.rig), _run(ds, ds.rig, disparity_offset={"enabled": False})


def test_a_consistent_rig_applies_nothing_and_rop_is_unchanged(consistent):
    """The estimate stays below its test (docs: 0.15-0.51 % of the median disparity on consistent rigs), so
    the tracker never shifts a right point and the trajectory equals the one without the estimate, bit for bit."""
    _, (est, poses), (_, poses_off) = consistent
    assert len(est.offset.estimate.fits) >= 3          # it was estimated, not skipped
    assert est.offset.delta_px == 0.0 and est.klt.right_shift_px == 0.0
    assert np.array_equal(poses, poses_off)


def test_a_written_offset_is_estimated_and_corrected(consistent):
    """1.5 px written (5-8 % of campus's 20-30 px disparities): the estimate is applied and recovers it within
    0.25 px (klt-pnp's, on the same kind of fits, is within 0.03 px over hundreds of keyframes; here 6 s give
    tens of keyframe fits on a distorted rig, whose offset the rectified-pair model only approximates), and the
    tracker's shift is the applied offset."""
    ds, _, _ = consistent
    est, _ = _run(ds, _written(ds.rig, 1.5))
    assert est.offset.delta_px == pytest.approx(1.5, abs=0.25)
    assert est.klt.right_shift_px == est.offset.delta_px


@pytest.mark.parametrize("shift_px", [0.0, 1.5])
def test_the_tracker_stores_right_points_corrected_by_the_shift(shift_px):
    """A textured right image that is the left one moved 7 px left (every true disparity 7 px): the keyframe's
    stored right points are the measured ones moved ``right_shift_px`` further, and the next frame's matches too."""
    rng = np.random.default_rng(5)
    left = cv2.GaussianBlur((rng.random((480, 640)) * 255).astype(np.uint8), (0, 0), 2.0)
    right = np.roll(left, -7, axis=1)
    klt = KltFourView(make_rig())
    klt.right_shift_px = shift_px
    klt.keyframe(left, right, {})
    v = klt.view
    inner = (v.p1[:, 0] > 20) & (v.p1[:, 0] < 600)
    assert inner.sum() > 50
    assert np.allclose(v.p1[inner, 0] - v.p2[inner, 0], 7.0 + shift_px, atol=0.05)
    v = klt.track(left, right, {})
    inner = v.ok4 & (v.p3[:, 0] > 20) & (v.p3[:, 0] < 600)
    assert np.allclose(v.p3[inner, 0] - v.p4[inner, 0], 7.0 + shift_px, atol=0.05)


@pytest.mark.parametrize("value, field", [({"min_keyframes": 0}, "min_keyframes"), ({"bogus": 1}, "bogus")])
def test_bad_offset_option_names_the_field(value, field):
    with pytest.raises(EstimatorError, match=rf"rop\.disparity_offset.*{field}"):
        RopEstimator(make_rig(), disparity_offset=value)
