"""The simulator's check of the KLT estimators at a third of the frame rate (docs/estimators.md, "Frame rate"):
``urban-kitti`` seed 23 through its intersection turn (the first 70 s: frames 636-657 turn at up to 13 deg per frame
read every third frame), ``bench real --stride 3``. From seed 003's zero-flow LK start the tracks do not reach across
the turn and both estimators lose and re-initialise frames (whole route: `klt-pnp` 27.8 %, `rop` 14.3 %; the real
KITTI turn at stride 3: `klt-pnp` 11.8 %); from the predicted pixels (:mod:`vo.estimators.track_prediction`,
:mod:`vo.rop.track_start`, the defaults) they hold (whole route: 0.65 % and 0.59 %). The bounds are the issue's 2 %
target and no failed frame: they catch a lost or broken prediction without real data."""
import pytest

from sim.app.bench_real import bench_real
from sim.scenarios import cached_dataset, get_scenario

FAILED = ("lost", "few_features", "reinit")


@pytest.fixture(scope="module")
def turn():
    return cached_dataset(get_scenario("urban-kitti", overrides=("duration_s=70",), seed=23), progress=False)


def _failed(row) -> int:
    return sum(row.status_counts.get(s, 0) for s in FAILED)


@pytest.mark.long
def test_klt_pnp_holds_a_fast_turn_from_the_predicted_start(turn):
    pred, = bench_real([turn], ("klt-pnp",), progress=False, stride=3)
    zero, = bench_real([turn], ("klt-pnp",), progress=False, stride=3,
                       options={"pnp_config": {"predict_tracks": False}})
    assert pred.n_frames == zero.n_frames == 234
    assert _failed(pred) == 0 and pred.drift_pct < 2.0
    assert _failed(zero) >= 2                                  # the zero-flow start fails there


@pytest.mark.long
def test_rop_holds_a_fast_turn_from_the_predicted_start(turn):
    pred, = bench_real([turn], ("rop",), progress=False, stride=3)
    zero, = bench_real([turn], ("rop",), progress=False, stride=3, options={"predict_tracks": False})
    assert _failed(pred) == 0 and pred.drift_pct < 2.0
    assert _failed(zero) >= 2
