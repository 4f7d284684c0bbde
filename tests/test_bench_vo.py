"""``vo-testbed bench vo`` rows: placeholder frames before the estimator's first pose are counted (class
``init``), and a run that never initialises gets NaN figures, so it is told apart from one that drifted."""
import numpy as np

from sim.app.bench_vo import bench_row, format_rows, unevaluated_row
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
from vo.pipeline import run_and_evaluate


def test_bench_row_counts_init_frames(campus_short):
    ds = open_dataset(campus_short)
    run = run_estimator("vins", ds, progress=False, max_frames=20)    # 2 s from rest: still initialising
    assert len(run.estimated()) == 0
    row = unevaluated_row("campus-short", "vins", run, ds)
    assert row.n_frames == 20 and row.n_init == 20
    assert np.isnan(row.drift_pct) and np.isnan(row.ate_rmse_m) and row.path_length_m > 0.0   # not scored
    res = run_and_evaluate(ds, "klt-pnp", progress=False, max_frames=20)
    row2 = bench_row("campus-short", "klt-pnp", res)
    assert row2.n_init == 0 and np.isfinite(row2.ate_rmse_m)      # stereo VO: its first frame is its origin
    lines = format_rows([row, row2]).splitlines()
    assert lines[0].split()[14:16] == ["lost", "init"]
    assert lines[1].split()[9] == "20" and lines[2].split()[9] == "0"
