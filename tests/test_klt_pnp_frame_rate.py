"""The simulator's check of ``klt-pnp`` at a third of the frame rate (docs/estimators.md, "Frame rate"): ``urban-kitti``
seed 23 through its intersection turn (the first 70 s: frames 636-657 turn at up to 13 deg per frame read every
third frame), ``bench real --stride 3``. From seed 003's zero-flow LK start the tracks do not reach across the turn
and the estimator loses and re-initialises frames (the whole route: 27.8 % drift; the real KITTI turn at stride 3:
11.8 %); from the landmarks' predicted pixels (:mod:`vo.estimators.track_prediction`, the default) it holds (the
whole route 0.65 %). The bounds are the issue's 2 % target and no lost frame: they catch a lost or broken
prediction without real data."""
import pytest

from sim.app.bench_real import bench_real
from sim.scenarios import cached_dataset, get_scenario


@pytest.mark.long
def test_klt_pnp_holds_a_fast_turn_from_the_predicted_start():
    data = cached_dataset(get_scenario("urban-kitti", overrides=("duration_s=70",), seed=23), progress=False)
    pred, = bench_real([data], ("klt-pnp",), progress=False, stride=3)
    zero, = bench_real([data], ("klt-pnp",), progress=False, stride=3,
                       options={"pnp_config": {"predict_tracks": False}})
    assert pred.n_frames == zero.n_frames == 234
    failed = ("lost", "few_features", "reinit")
    assert not any(pred.status_counts.get(s, 0) for s in failed) and pred.drift_pct < 2.0
    assert sum(zero.status_counts.get(s, 0) for s in failed) >= 2            # the zero-flow start fails there
