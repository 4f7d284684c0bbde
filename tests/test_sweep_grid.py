"""`vo-testbed sweep`: grid parsing and validation before anything runs, tables, the 1/b model (no rendering)."""
import sys

import numpy as np
import pytest

from sim.app.sweep.grid import SweepError, load_spec, parse_axis, parse_seeds, spec_from_cli
from sim.scenarios import get_scenario


def test_axis_values_are_parsed_as_yaml():
    assert parse_axis("baseline=0.063,0.12") == ("baseline", (0.063, 0.12))
    assert parse_axis("scene.name=campus, indoor") == ("scene.name", ("campus", "indoor"))
    assert parse_axis("scene.shadows=true,false") == ("scene.shadows", (True, False))
    for bad in ("baseline", "baseline=", "=1,2", "baseline=0.1,,0.2"):
        with pytest.raises(SweepError, match="--grid"):
            parse_axis(bad)


def test_seeds_range_excludes_stop_like_python():
    assert parse_seeds("0:5") == (0, 1, 2, 3, 4)
    assert parse_seeds("3,7") == (3, 7)
    assert parse_seeds([2]) == (2,)
    for bad in ("5:5", "a:b", "", "1:2:3"):
        with pytest.raises(SweepError, match="--seeds"):
            parse_seeds(bad)


def test_cell_key_is_the_hash_of_the_resolved_configuration():
    spec = spec_from_cli("smoke", ("baseline=0.12,0.27",), "klt-pnp", "0:2")
    cells = spec.cells()
    assert [(dict(c.values)["baseline"], c.seed) for c in cells] == [(0.12, 0), (0.12, 1), (0.27, 0), (0.27, 1)]
    for c in cells:
        expected = get_scenario("smoke", [f"baseline={dict(c.values)['baseline']}"], seed=c.seed)
        assert c.key == expected.config_hash()
        assert c.config.rig.baseline == pytest.approx(dict(c.values)["baseline"])
    assert len({c.key for c in cells}) == 4


@pytest.mark.parametrize("axis, words", [
    ("bogus=1,2", ["--grid 'bogus=1'", "unknown key"]),
    ("scene.texture_richness=0.5,1.5", ["--grid 'scene.texture_richness=1.5'", "texture_richness", "1.5"]),
    ("render.supersample=2", ["supersample", "odd"]),
])
def test_bad_grid_values_fail_before_anything_runs(axis, words):
    spec = spec_from_cli("smoke", (axis,), "klt-pnp", "0:1")
    with pytest.raises(SweepError) as e:
        spec.cells()
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_spec_level_errors():
    with pytest.raises(SweepError, match="axis given twice"):
        spec_from_cli("smoke", ("baseline=0.1", "baseline=0.2"), "rop", "0:1")
    with pytest.raises(SweepError, match="--estimator 'nope'"):
        spec_from_cli("smoke", ("baseline=0.1",), "nope", "0:1")
    with pytest.raises(SweepError, match="at least one axis"):
        spec_from_cli("smoke", (), "rop", "0:1")
    with pytest.raises(SweepError, match="unknown scenario"):
        spec_from_cli("nowhere", ("baseline=0.1",), "rop", "0:1").cells()


def test_yaml_spec_equals_the_command_line(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text("scenario: smoke\ngrid:\n  baseline: [0.12, 0.27]\n  scene.texture_richness: [0.3, 1.0]\n"
                    "estimators: [rop, klt-pnp]\nseeds: '0:2'\nset: [duration_s=1]\n")
    from_file = load_spec(path)
    from_cli = spec_from_cli("smoke", ("baseline=0.12,0.27", "scene.texture_richness=0.3,1.0"), ("rop", "klt-pnp"),
                             "0:2", ("duration_s=1",))
    assert from_file == from_cli
    assert [c.key for c in from_file.cells()] == [c.key for c in from_cli.cells()]
    path.write_text("scenario: smoke\ngird: {baseline: [0.1]}\n")
    with pytest.raises(SweepError, match="gird: unknown key"):
        load_spec(path)


def _cli(capsys, *args):
    from sim.app.cli import main
    with pytest.raises(SystemExit) as e:
        main(["sweep", *args])
    return e.value.code, capsys.readouterr().err.strip()


def test_cli_bad_grid_exits_2_with_one_line_and_runs_nothing(tmp_path, capsys):
    out = tmp_path / "sweep"
    code, err = _cli(capsys, "--scenario", "smoke", "--grid", "scene.texture_richness=2", "--out", str(out))
    assert code == 2 and err.count("\n") == 0 and err.startswith("error: ") and "texture_richness" in err
    assert not out.exists()


def test_without_dask_the_command_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)      # import fails as if not installed
    code, err = _cli(capsys, "--scenario", "smoke", "--grid", "baseline=0.1", "--out", str(tmp_path / "s"))
    assert code == 2 and err == "error: the sweep needs Dask distributed: pip install 'vo-testbed[sweep]'"


def _record(key, seed, b, drift, error=None):
    run = {"error": error} if error else {"error": None, "drift_pct": drift, "ate_rmse_m": drift / 10,
                                          "rpe_trans_rmse_m": 0.01, "n_lost": 0, "n_frames": 10, "ms_per_frame": 5.0}
    return {"key": key, "seed": seed, "values": {"baseline": b}, "error": None, "runs": {"rop": run}}


def test_aggregate_groups_seeds_per_grid_point_and_skips_failures():
    from sim.app.sweep.table import aggregate, tidy_rows
    drifts = {0.1: [3.0, 1.0, 2.0, 10.0], 0.2: [0.5, 0.7, 0.6, 0.0]}
    records = [_record(f"{b}-{s}", s, b, d) for b, ds in drifts.items() for s, d in enumerate(ds)]
    records[-1] = _record("0.2-3", 3, 0.2, 0.0, error="EstimatorError: lost")
    rows = tidy_rows(records, ["baseline"], ["rop"])
    assert [r["baseline"] for r in rows] == [0.1] * 4 + [0.2] * 4
    assert rows[-1]["error"] == "EstimatorError: lost" and np.isnan(rows[-1]["drift_pct"])
    agg = {a["baseline"]: a for a in aggregate(rows, ["baseline"])}
    for b, ds in ((0.1, drifts[0.1]), (0.2, drifts[0.2][:3])):      # the failed seed is left out
        q1, med, q3 = np.percentile(ds, [25, 50, 75])
        assert agg[b]["drift_pct_median"] == pytest.approx(med)
        assert (agg[b]["drift_pct_q1"], agg[b]["drift_pct_q3"]) == pytest.approx((q1, q3))
        assert (agg[b]["drift_pct_min"], agg[b]["drift_pct_max"]) == (min(ds), max(ds))
    assert (agg[0.2]["n_ok"], agg[0.2]["n_failed"]) == (3, 1)


def test_baseline_model_is_eq7_scaled_at_the_reference():
    from sim.app.sweep.plots import predicted_drift
    from vo.errorprop.range import range_sigma
    b = np.array([0.063, 0.12, 0.27, 0.5])
    pred = predicted_drift(b, 0.27, 0.8, fx_px=458.0)
    assert pred[2] == pytest.approx(0.8)
    # eq. 7 at any range: sigma_r(b) / sigma_r(b_ref) = b_ref / b
    assert pred == pytest.approx(0.8 * range_sigma(25.0, b, 458.0, 0.5) / range_sigma(25.0, 0.27, 458.0, 0.5))
    assert pred == pytest.approx(0.8 * 0.27 / b)


def test_which_records_count_as_done():
    from sim.app.sweep.cell import is_done
    ok = {"error": None, "runs": {"rop": {"error": None}, "klt-pnp": {"error": None}}}
    est_failed = {"error": None, "runs": {"rop": {"error": "EstimatorError: lost"}, "klt-pnp": {"error": None}}}
    gen_failed = {"error": "SimError: bad scene", "runs": {}}
    assert is_done(ok, ("rop", "klt-pnp")) and is_done(ok, ("rop",))
    assert not is_done(ok, ("rop", "orb-pnp"))            # a new estimator: the cell runs again
    assert not is_done(None, ("rop",))
    for failed in (est_failed, gen_failed):               # recorded failures are final unless retried
        assert is_done(failed, ("rop", "klt-pnp"))
        assert not is_done(failed, ("rop", "klt-pnp"), retry_failed=True)
