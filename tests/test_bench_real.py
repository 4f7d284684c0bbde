"""``vo-testbed bench real``: the real-recording benchmark on the real KITTI excerpt (skipped when the data is not
beside the repository) and on a tiny generated dataset in both layouts (EuRoC and KITTI)."""
import json
import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sim.app.bench_real import bench_real, format_rows, ground_axes, segment_errors
from sim.app.cli import cli, main
from sim.errors import SimError
from rigs.trajectory import Trajectory

REPO = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("VO_TESTBED_REAL_DATA", REPO.parent / "shared" / "data" / "real"))


def _straight(n, step, scale=1.0):
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, 2, 3] = np.arange(n) * step * scale
    return Trajectory(np.arange(n, dtype=np.int64) * 100_000_000, T, "w", "c0")


def test_segment_errors_only_where_the_route_is_long_enough():
    gt = _straight(301, 1.0)                                   # 300 m: devkit lengths 100, 200, 300 fit
    t_err, r_err, n = segment_errors(gt, _straight(301, 1.0, 1.02))
    # devkit: a segment of length L ends at the first pose beyond L (L + 1 m here), first poses every 10th:
    # 20 segments of 101 m, 10 of 201 m, none of 300 m (no pose beyond 300 m); 2 % of each over L
    assert n == 30 and r_err == pytest.approx(0.0, abs=1e-12)
    assert t_err == pytest.approx((20 * 2.0 * 101 / 100 + 10 * 2.0 * 201 / 200) / 30, abs=1e-9)
    t_err, _, n = segment_errors(_straight(51, 1.0), _straight(51, 1.0, 1.02))    # 50 m: no devkit segment
    assert n == 0 and np.isnan(t_err)


def test_ground_axes_pick_the_plane_of_travel():
    p = np.c_[np.linspace(0, 40, 10), np.linspace(0, -0.8, 10), np.linspace(0, 20, 10)]   # KITTI camera: x, z
    assert ground_axes(p) == (0, 2)


@pytest.mark.slow
def test_bench_real_on_the_kitti_excerpt(tmp_path):
    """The real 98-degree turn (docs/estimators.md, "Real recordings"). ``rop`` measured 1.65 % (5.51 % while its
    moving-object step cross-check failed frames on which the track filter had seen one rigid motion only:
    this bound catches that); ``klt-pnp`` 3.00 % with its online disparity-offset correction
    (``vo.estimators.disparity_offset``; 5.00 % with the close/far split instead, 11.03 % with neither): the
    bound is ORB-SLAM3's 4.7 % on these frames."""
    seq = REAL / "kitti_turn"
    if not seq.is_dir():
        pytest.skip(f"{seq}: real KITTI excerpt not present")
    rows = bench_real([seq], ("rop", "klt-pnp"), out_dir=tmp_path, progress=False)
    for r in rows:
        assert r.n_frames == 51 and sum(r.status_counts.values()) == 51
        assert r.path_length_m == pytest.approx(51.76, abs=0.01)          # summed steps of poses/00.txt
        assert r.kitti_segments == 0                                       # 52 m: shorter than the devkit's 100 m
        assert np.isfinite(r.ate_rmse_m) and r.ms_per_frame > 0 and Path(r.plot).is_file()
    rop, klt = rows
    assert rop.drift_pct < 2.5 and rop.status_counts.get("lost", 0) <= 5
    assert 0.0 < klt.drift_pct < 4.7


@pytest.mark.slow
def test_bench_real_cli_on_a_generated_dataset_in_both_layouts(tmp_path):
    from sim.generate_config import GenerateConfig
    from sim.generate import generate
    data = tmp_path / "data"
    generate(GenerateConfig(scene="campus", rig="cart27", duration_s=3.0, seed=1, format="both"), data, progress=False)
    out = tmp_path / "out"
    res = CliRunner().invoke(cli, ["bench", "real", "--dataset", str(data / "euroc"), "--dataset",
                                   str(data / "kitti" / "sequences" / "00"), "--estimator", "klt-pnp",
                                   "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    rows = json.loads(res.output)
    assert len(rows) == 2 and rows[0]["recording"] != rows[1]["recording"]
    for r in rows:
        assert r["n_frames"] == rows[0]["n_frames"] >= 30 and sum(r["status_counts"].values()) == r["n_frames"]
        # the same simulated drive read through both layouts: the same route, small drift
        assert r["path_length_m"] == pytest.approx(rows[0]["path_length_m"], rel=1e-3)
        assert r["drift_pct"] < 5.0 and Path(r["plot"]).is_file()


def test_bench_real_bad_dataset_is_one_line_and_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["bench", "real", "--dataset", str(tmp_path / "missing")])
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and len(err.splitlines()) == 1 and "missing: dataset folder not found" in err


@pytest.mark.slow
def test_bench_real_noise_draws_are_seeded_paired_and_leave_the_recorded_run_alone(tmp_path, capsys):
    """Each draw is a run on the recording with seeded image noise added: the same draws twice give the same
    drifts to the bit, two draws differ from each other, and the recorded run's figures are those of a bench
    without draws."""
    from sim.generate_config import GenerateConfig
    from sim.generate import generate
    data = tmp_path / "data"
    generate(GenerateConfig(scene="campus", rig="cart27", duration_s=2.0, seed=3), data, progress=False)
    plain = bench_real([data], ("klt-pnp",), progress=False)
    capsys.readouterr()
    drawn = bench_real([data], ("klt-pnp",), progress=True, noise_draws=2, noise_sigma=1.0)
    assert "klt-pnp, noise draw 2 of 2 (+1 grey levels)" in capsys.readouterr().err      # progress names the draw
    again = bench_real([data], ("klt-pnp",), progress=False, noise_draws=2, noise_sigma=1.0)
    assert plain[0].drift_draws_pct == [] and plain[0].noise_sigma == 0.0
    assert drawn[0].drift_pct == plain[0].drift_pct and drawn[0].ate_rmse_m == plain[0].ate_rmse_m
    assert len(drawn[0].drift_draws_pct) == 2 and drawn[0].noise_sigma == 1.0
    assert drawn[0].drift_draws_pct == again[0].drift_draws_pct
    d0, d1 = drawn[0].drift_draws_pct
    assert np.isfinite([d0, d1]).all() and d0 != d1
    assert "under re-drawn image noise" in format_rows(drawn) and "re-drawn" not in format_rows(plain)


def test_bench_real_bad_noise_options_are_refused(tmp_path, capsys):
    for args in (["--noise-draws", "-1"], ["--noise-draws", "2", "--noise-sigma", "0"]):
        with pytest.raises(SystemExit) as e:
            main(["bench", "real", "--dataset", str(tmp_path), *args])
        err = capsys.readouterr().err.strip()
        assert e.value.code == 2 and len(err.splitlines()) == 1 and "--noise-" in err, err
    with pytest.raises(SimError, match="noise_sigma"):
        bench_real([tmp_path], ("klt-pnp",), noise_draws=1, noise_sigma=float("nan"))
    with pytest.raises(SimError, match="noise_draws"):
        bench_real([tmp_path], ("klt-pnp",), noise_draws=-2)


@pytest.mark.slow
def test_the_kitti_excerpt_holds_the_target_over_noise_draws():
    """The 2 % target on the real turn judged over 4 draws of added image noise (0.5 grey levels), not on the one
    recording, whose figure a few matches decide (docs/estimators.md, "How far the noise alone moves these
    figures": over 8 draws `rop` 1.08-1.74 %, `klt-pnp` 0.44-1.22 %, medians 1.24 / 0.79; `rop` without its
    disparity-offset estimate median 2.25, worst 3.10). The median must meet the target and no draw may pass
    2.5 %."""
    seq = REAL / "kitti_turn"
    if not seq.is_dir():
        pytest.skip(f"{seq}: real KITTI excerpt not present")
    rows = bench_real([seq], ("rop", "klt-pnp"), progress=False, noise_draws=4)
    for r in rows:
        d = np.asarray(r.drift_draws_pct)
        assert len(d) == 4 and np.median(d) <= 2.0 and d.max() <= 2.5, (r.estimator, d)
