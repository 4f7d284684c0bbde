"""The simulator's prediction of the real KITTI turn's failure (docs/estimators.md, "The simulator's
prediction"): ``urban-kitti-calib`` is ``urban-kitti`` through the stop and the 90-degree turn with a written
calibration whose disparity is off (``calib_error.stereo_disparity_px``), the cause measured on the real
excerpt, 3.0 px. Before the fix of ``rop``'s moving-object step cross-check ``rop`` lost 37 frames there and
drifted 4.28 % (real turn: 9 lost frames, 5.51 %); with it 17 lost frames, 3.19 % (the rest: the offset splits
the static world into two "motions", near and far). The bounds lie between the two and catch that regression
without real data."""
import pytest

from sim.scenarios import cached_dataset, get_scenario
from vo.dataset import open_dataset
from vo.pipeline import run_and_evaluate


@pytest.mark.long
def test_rop_holds_under_a_stereo_disparity_offset():
    ds = open_dataset(cached_dataset(get_scenario("urban-kitti-calib"), progress=False))
    res = run_and_evaluate(ds, "rop", progress=False)
    lost = sum(f.status == "lost" for f in res.run.frames)
    assert lost <= 25 and res.evaluation.drift.drift_ratio_pct < 3.8


@pytest.mark.long
def test_klt_pnp_estimates_and_corrects_the_disparity_offset():
    """``klt-pnp``'s online offset estimate (``vo.estimators.disparity_offset``) on the same scenario: measured
    3.024 px for the written 3.0 px, drift 0.86 % (11.1 % without the correction, the real turn's failure); the
    bounds catch a biased estimate or a lost correction."""
    ds = open_dataset(cached_dataset(get_scenario("urban-kitti-calib"), progress=False))
    res = run_and_evaluate(ds, "klt-pnp", progress=False)
    assert res.run.estimator.offset.delta_px == pytest.approx(3.0, abs=0.1)
    assert res.evaluation.drift.drift_ratio_pct < 2.5
