"""``vo-testbed bench vo`` rows: placeholder frames before the estimator's first pose are counted (class
``init``), and a run that never initialises gets NaN figures, so it is told apart from one that drifted."""
import json
import os
import subprocess
import sys

import numpy as np
import yaml

from sim.app.bench_vo import bench_row, format_rows, unevaluated_row
from sim.app.check import scenario_dataset
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


def test_bench_vo_set_reaches_the_scenario_and_bad_keys_exit_2(tmp_path, monkeypatch):
    """``bench vo --set`` configures the benchmarked scenario as ``check --set`` does (a held-out seed, a 1 s
    route: 11 frames at 10 Hz where ``campus-short`` has 101), in real processes with a private cache; the
    row's path is that of the dataset the overrides name, and a wrong key or value is one line, exit 2."""
    env = {**os.environ, "MUJOCO_GL": "egl", "VO_TESTBED_CACHE": str(tmp_path / "cache")}
    exe = [sys.executable, "-c", "import sys; from sim.app.cli import main; sys.argv[0] = 'vo-testbed'; main()",
           "bench", "vo", "--scenario", "campus-short", "--estimator", "klt-pnp", "--no-progress"]
    overrides = ("seed=5", "duration_s=1")
    r = subprocess.run(exe + [a for o in overrides for a in ("--set", o)] + ["--json"], capture_output=True,
                       text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    row, = json.loads(r.stdout)
    assert row["n_frames"] == 11 and row["scenario"] == "campus-short"
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "cache"))
    ds = open_dataset(scenario_dataset("campus-short", overrides, progress=False))   # the cached entry
    assert yaml.safe_load((ds.path / "metadata.yaml").read_text())["seed"] == 5
    T = ds.groundtruth_cam0().T
    assert np.isclose(row["path_length_m"], np.sum(np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)))
    for bad, needle in (("nosuch=1", "nosuch: unknown key"), ("render.supersample=4", "must be odd")):
        r = subprocess.run(exe + ["--set", bad], capture_output=True, text=True, env=env, timeout=600)
        lines = [line for line in r.stderr.splitlines() if line.strip()]
        assert r.returncode == 2 and len(lines) == 1 and needle in lines[0], r.stderr
