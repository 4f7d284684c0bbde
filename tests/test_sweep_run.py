"""`vo-testbed sweep` on Dask: a LocalCluster run builds the table, a failing cell is recorded while the
others complete, a partial sweep resumes and a finished one re-runs without work; a separately started
scheduler and worker give identical results; SIGINT leaves a sweep that resumes (the last two slow);
a record made by other code (another code fingerprint) is run again, or kept with --keep-stale.

Cells are 0.5 s of the `smoke` scenario (11 frames at 20 Hz), a few seconds each.
"""
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("dask.distributed")

from foreground import foreground_sigint                          # noqa: E402
from sim.app.sweep.cell import record_path                       # noqa: E402
from sim.app.sweep.driver import run_sweep                       # noqa: E402
from sim.app.sweep.fingerprint import code_fingerprint           # noqa: E402
from sim.app.sweep.grid import spec_from_cli                     # noqa: E402
from sim.app.sweep.table import DETERMINISTIC                    # noqa: E402
from vo.estimators.pnp import KltPnpEstimator                    # noqa: E402
from vo.errors import EstimatorError                             # noqa: E402

HERE = Path(__file__).resolve().parent
FAILING = "test_sweep_run:WideBaselineRefused"
GRID = ("baseline=0.12,0.27",)


class WideBaselineRefused(KltPnpEstimator):
    """klt-pnp that refuses rigs wider than 0.2 m: a cell whose estimator fails for a known reason."""

    def __init__(self, rig, **options):
        if rig.baseline > 0.2:
            raise EstimatorError(f"baseline {rig.baseline:g} m > 0.2 m refused by the test plug-in")
        super().__init__(rig, **options)


def _spec():
    return spec_from_cli("smoke", GRID, ("klt-pnp", FAILING), "0:1", ("duration_s=0.5",))


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _mtimes(out, cells):
    return {c.key: record_path(out, c.key).stat().st_mtime_ns for c in cells}


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """The 2-cell sweep run in two goes on a 2-worker LocalCluster: one cell, then the rest, then again."""
    out = tmp_path_factory.mktemp("sweep_local")
    spec = _spec()
    first = run_sweep(spec, out, workers=2, progress=False, max_cells=1)
    after_first = _mtimes(out, spec.cells()[:1])
    second = run_sweep(spec, out, workers=2, progress=False)
    after_second = _mtimes(out, spec.cells())
    third = run_sweep(spec, out, workers=2, progress=False)
    return out, spec, (first, second, third), (after_first, after_second, _mtimes(out, spec.cells()))


def test_local_cluster_sweep_writes_the_tidy_table(local_sweep):
    out, spec, _, _ = local_sweep
    rows = _rows(out / "results.csv")
    n_frames = round(0.5 * spec.cells()[0].config.rig.camera_rate_hz) + 1       # frames at 0, 1/rate, ..., 0.5 s
    assert [(float(r["baseline"]), r["estimator"]) for r in rows] == \
        [(0.12, "klt-pnp"), (0.12, FAILING), (0.27, "klt-pnp"), (0.27, FAILING)]
    for r in rows:
        assert r["key"] in {c.key for c in spec.cells()}
        if not r["error"]:
            assert int(r["n_frames"]) == n_frames and float(r["ate_rmse_m"]) >= 0 and float(r["ms_per_frame"]) > 0
    agg = _rows(out / "aggregate.csv")
    assert len(agg) == 4 and {a["n_ok"] for a in agg} == {"0", "1"}
    for name in ("lines_baseline.png", "baseline_prediction.png"):
        assert (out / "plots" / name).stat().st_size > 0
    assert not list(out.glob("work/*"))          # datasets deleted after use


def test_failed_cell_is_recorded_and_the_others_complete(local_sweep):
    out, _, (_, second, _), _ = local_sweep
    rows = {(float(r["baseline"]), r["estimator"]): r for r in _rows(out / "results.csv")}
    assert "baseline 0.27 m > 0.2 m refused" in rows[(0.27, FAILING)]["error"]
    assert rows[(0.27, FAILING)]["drift_pct"] == ""
    for key in ((0.12, "klt-pnp"), (0.12, FAILING), (0.27, "klt-pnp")):
        assert rows[key]["error"] == "" and float(rows[key]["drift_pct"]) >= 0
    # the refusing plug-in is klt-pnp itself on the narrow rig: same figures
    for m in DETERMINISTIC:
        assert rows[(0.12, FAILING)][m] == rows[(0.12, "klt-pnp")][m]
    assert second.n_failed == 1


def test_partial_sweep_resumes_and_finished_one_does_no_work(local_sweep):
    _, spec, (first, second, third), (m1, m2, m3) = local_sweep
    assert (first.n_run, first.n_skipped) == (1, 0)
    assert (second.n_run, second.n_skipped) == (1, 1)
    assert (third.n_run, third.n_skipped) == (0, 2)
    key0 = spec.cells()[0].key
    assert m2[key0] == m1[key0]            # the resumed run left the finished cell alone
    assert m3 == m2                        # the re-run rewrote no record


def test_report_redraws_from_the_records(local_sweep, capsys):
    out, _, _, _ = local_sweep
    from sim.app.cli import main
    before = (out / "results.csv").read_text()
    (out / "plots" / "lines_baseline.png").unlink()
    (out / "results.csv").unlink()
    main(["sweep", "report", str(out)])
    assert "1 failed cells" in capsys.readouterr().out
    assert (out / "results.csv").read_text() == before
    assert (out / "plots" / "lines_baseline.png").exists()


OLD_CODE = "0123456789abcdef"


def _cli_args(out):
    return ["sweep", "--scenario", "smoke", "--set", "duration_s=0.5", "--grid", GRID[0], "--estimator",
            f"klt-pnp,{FAILING}", "--seeds", "0:1", "--no-progress", "--out", str(out)]


def test_stale_record_runs_again_unless_kept(local_sweep, tmp_path, capsys):
    """A copy of the finished sweep whose first record is marked as made by other code."""
    from sim.app.cli import main
    src, spec, _, _ = local_sweep
    out = tmp_path / "sweep"
    shutil.copytree(src, out)
    code, cells = code_fingerprint(), spec.cells()
    stale, current = cells[0].key, cells[1].key
    assert json.loads((out / "sweep.json").read_text())["code"] == code
    for c in cells:                                       # the workers ran this very code
        assert json.loads(record_path(out, c.key).read_text())["code"] == code
    rec = json.loads(record_path(out, stale).read_text())
    record_path(out, stale).write_text(json.dumps(dict(rec, code=OLD_CODE)))
    before = _mtimes(out, cells)

    main(_cli_args(out) + ["--keep-stale"])               # kept: nothing runs, the mix is reported
    std = capsys.readouterr()
    assert "2 cells: 0 run, 2 already done, 1 failed, 1 stale kept (records made by other code)" in std.out
    assert f"warning: the records come from 2 code versions ({OLD_CODE}: 1 cells, {code} (current): 1 cells)" \
        in std.err
    assert _mtimes(out, cells) == before
    assert {r["key"]: r["code"] for r in _rows(out / "results.csv")} == {stale: OLD_CODE, current: code}
    main(["sweep", "report", str(out)])
    assert std.err.strip() in capsys.readouterr().err

    again = run_sweep(spec, out, workers=1, progress=False)           # default: the stale cell runs again
    assert (again.n_run, again.n_skipped, again.n_stale, again.n_stale_run) == (1, 1, 1, 1)
    after = _mtimes(out, cells)
    assert after[current] == before[current] and after[stale] != before[stale]
    assert again.code_counts == {code: 2}
    assert json.loads(record_path(out, stale).read_text())["code"] == code
    for a, b in zip(_rows(src / "results.csv"), _rows(out / "results.csv")):      # same code, same figures
        assert {m: a[m] for m in DETERMINISTIC + ("key", "code", "error")} == \
            {m: b[m] for m in DETERMINISTIC + ("key", "code", "error")}
    main(["sweep", "report", str(out)])
    assert "warning" not in capsys.readouterr().err


def _env():
    return dict(os.environ, MUJOCO_GL="egl", PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]))


def _wait_for(path: Path, timeout_s: float):
    t_end = time.monotonic() + timeout_s
    while not path.exists() and time.monotonic() < t_end:
        time.sleep(0.2)
    return path.exists()


@pytest.mark.slow
def test_separate_scheduler_and_worker_give_identical_results(local_sweep, tmp_path):
    out_local, spec, _, _ = local_sweep
    dask = Path(sys.executable).with_name("dask")
    sched_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(sched_file)], env=_env(), stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        assert _wait_for(sched_file, 60), "dask scheduler did not start"
        procs.append(subprocess.Popen([str(dask), "worker", "--scheduler-file", str(sched_file), "--host", "127.0.0.1",
                                       "--nthreads", "1", "--nworkers", "1", "--no-dashboard"], env=_env(),
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        import json
        address = json.loads(sched_file.read_text())["address"]
        out = tmp_path / "sweep"
        summary = run_sweep(spec, out, scheduler=address, progress=False)
        assert summary.n_run == 2
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(timeout=30)
    local, remote = _rows(out_local / "results.csv"), _rows(out / "results.csv")
    assert [(r["key"], r["estimator"], r["error"]) for r in remote] == \
        [(r["key"], r["estimator"], r["error"]) for r in local]
    for a, b in zip(local, remote):
        assert {m: a[m] for m in DETERMINISTIC} == {m: b[m] for m in DETERMINISTIC}


@pytest.mark.slow
def test_sigint_interrupted_sweep_resumes(tmp_path):
    out = tmp_path / "sweep"
    args = [str(Path(sys.executable).with_name("vo-testbed")), "sweep", "--scenario", "smoke", "--set", "duration_s=0.5",
            "--grid", "scene.texture_richness=0.2,0.4,0.6,0.8", "--estimator", "klt-pnp", "--seeds", "0:1",
            "--workers", "1", "--no-progress", "--out", str(out)]
    proc = subprocess.Popen(args, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=foreground_sigint)
    try:
        assert _wait_for(out / "cells", 120) and _first_record(out / "cells", 120), "no cell finished"
        os.killpg(proc.pid, signal.SIGINT)      # as Ctrl-C does: the whole process group
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert "run the same command again to resume" in err
    done = {p.name: p.stat().st_mtime_ns for p in (out / "cells").glob("*.json")}
    assert 1 <= len(done) < 4
    resumed = subprocess.run(args, env=_env(), capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{4 - len(done)} run, {len(done)} already done, 0 failed" in resumed.stdout
    assert all((out / "cells" / name).stat().st_mtime_ns == t for name, t in done.items())
    again = subprocess.run(args, env=_env(), capture_output=True, text=True, timeout=120)
    assert "0 run, 4 already done" in again.stdout


def _first_record(cells: Path, timeout_s: float) -> bool:
    t_end = time.monotonic() + timeout_s
    while not any(cells.glob("*.json")) and time.monotonic() < t_end:
        time.sleep(0.2)
    return any(cells.glob("*.json"))
