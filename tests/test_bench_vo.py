"""``vo-testbed bench vo`` rows: frames before the estimator's first pose are counted (status ``init``), so a
run that never initialises (drift 100 %) is told apart from one that drifted."""
import numpy as np

from sim.app.bench_vo import bench_row, format_rows
from vo.dataset import open_dataset
from vo.pipeline import run_and_evaluate


def test_bench_row_counts_init_frames(campus_short):
    ds = open_dataset(campus_short)
    res = run_and_evaluate(ds, "vins", progress=False, max_frames=20)    # 2 s from rest: still initialising
    row = bench_row("campus-short", "vins", res)
    assert row.n_frames == 20 and row.n_init == 20
    assert row.drift_pct > 99.0        # identity poses while initialising: end error = the (nearly straight) path
    res = run_and_evaluate(ds, "klt-pnp", progress=False, max_frames=20)
    row2 = bench_row("campus-short", "klt-pnp", res)
    assert row2.n_init == 1 and np.isfinite(row2.ate_rmse_m)      # stereo VO: only the reference frame
    lines = format_rows([row, row2]).splitlines()
    assert lines[0].split()[14:16] == ["lost", "init"]
    assert lines[1].split()[9] == "20" and lines[2].split()[9] == "1"
