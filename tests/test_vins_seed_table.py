"""Seed 002 tables over several seeds: medians over the seeds that initialised, the improvement as the
median of the per-seed improvements (not the improvement of the medians)."""
from studies import load_study

_study = load_study("vins_tables")
format_seed_table, seed_medians = _study.format_seed_table, _study.seed_medians


def _row(name, rpe=None, drift=None, dyn=30.0):
    r = {"name": name, "n_lt_10_pct": 60.0, "true_dynamic_pct": dyn, "static_as_outlier_pct": 50.0,
         "dynamic_as_inlier_pct": 40.0, "init_frame": 70 if rpe else 250}
    if rpe is not None:
        r.update(rpe10=[rpe, rpe / 2, rpe * 3], drift_pct=drift)
    return r


def test_medians_over_initialised_seeds_and_median_of_per_seed_improvements():
    runs = {1: [_row("vins", 1.0, 2.0), _row("vins-ac-me", 0.5, 1.0), _row("vins-oracle", dyn=0.0)],
            2: [_row("vins", 2.0, 4.0), _row("vins-ac-me", 3.0, 5.0), _row("vins-oracle", 1.0, 3.0, 0.0)],
            3: [_row("vins", 4.0, 6.0), _row("vins-ac-me", 3.0, 9.0), _row("vins-oracle", dyn=0.0)]}
    rows = {r["name"]: r for r in seed_medians(runs)}
    assert rows["vins"]["seeds_initialised"] == 3 and rows["vins"]["rpe10"] == [2.0, 1.0, 6.0]
    # per-seed improvements of ac-me: +50 %, -50 %, +25 % -> median +25 % (medians' ratio would give -50 %)
    assert rows["vins-ac-me"]["improvement_pct"] == 25.0 and rows["vins-ac-me"]["drift_pct"] == 5.0
    assert rows["vins-oracle"]["seeds_initialised"] == 1 and rows["vins-oracle"]["improvement_pct"] == 50.0
    assert rows["vins-oracle"]["true_dynamic_pct"] == 0.0 and rows["vins"]["improvement_pct"] is None
    text = format_seed_table(runs)
    assert "| vins-oracle | 1 of 3 | 1.000 |" in text and "+25.0 %" in text
    assert "vins-oracle, RPE mean / drift per seed: 1: no initialisation; 2: 1.00 m / 3.0 %" in text
