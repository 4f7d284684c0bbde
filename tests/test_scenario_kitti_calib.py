"""The simulator's prediction of the real KITTI turn's failure (docs/estimators.md, "The simulator's
prediction"): ``urban-kitti-calib`` is ``urban-kitti`` through the stop and the 90-degree turn with a written
calibration whose disparity is off (``calib_error.stereo_disparity_px``), the cause measured on the real
excerpt, 3.0 px. Without the online offset estimate ``rop`` fails there as on the real turn: 27 frames lost to the
track filter, which sees near and far points as two motions and hands those frames its long PnP step, 6.01 %
drift (``--opt 'disparity_offset={enabled: false}'``; real turn before its fixes: 9 lost frames, 5.51 %); with the
estimate (:mod:`vo.rop.offset`) none is lost and the drift is 0.76 %. The bounds are the issue's 2 % target and a
handful of lost frames: they catch a lost or biased correction without real data."""
import pytest

from sim.scenarios import cached_dataset, get_scenario
from vo.dataset import open_dataset
from vo.pipeline import run_and_evaluate


@pytest.mark.long
def test_rop_holds_under_a_stereo_disparity_offset():
    ds = open_dataset(cached_dataset(get_scenario("urban-kitti-calib"), progress=False))
    res = run_and_evaluate(ds, "rop", progress=False)
    lost = sum(f.status == "lost" for f in res.run.frames)
    assert lost <= 5 and res.evaluation.drift.drift_ratio_pct < 2.0


@pytest.mark.long
def test_klt_pnp_estimates_and_corrects_the_disparity_offset():
    """``klt-pnp``'s online offset estimate (``vo.estimators.disparity_offset``) on the same scenario: measured
    3.024 px for the written 3.0 px, drift 0.86 % (11.1 % without the correction, the real turn's failure); the
    bounds catch a biased estimate or a lost correction."""
    ds = open_dataset(cached_dataset(get_scenario("urban-kitti-calib"), progress=False))
    res = run_and_evaluate(ds, "klt-pnp", progress=False)
    assert res.run.estimator.offset.delta_px == pytest.approx(3.0, abs=0.1)
    assert res.evaluation.drift.drift_ratio_pct < 2.5
