"""`vo-testbed check`: the CI gate passes within bounds, fails past them, and runs external commands."""
import json
import sys

import pytest
from click.testing import CliRunner

from sim.app.cli import cli


@pytest.fixture
def cache(tmp_path_factory, monkeypatch):
    root = tmp_path_factory.getbasetemp() / "vo-cache"      # shared by the tests of this module
    monkeypatch.setenv("VO_TESTBED_CACHE", str(root))
    return root


def run_check(*args):
    return CliRunner().invoke(cli, ["check", "--scenario", "smoke", "--no-progress", "--json", *args])


def test_check_passes_and_fails_on_bounds(cache):
    ok = run_check("--estimator", "klt-pnp", "--max-drift", "5.0", "--max-rpe", "0.05")
    assert ok.exit_code == 0, ok.output
    res = json.loads(ok.output)
    assert res["passed"] and res["figures"]["max_drift"] < 5.0
    # the same run against an impossible bound: exit code 1 and the failing bound named
    bad = run_check("--estimator", "klt-pnp", "--max-ate", "1e-9")
    assert bad.exit_code == 1
    assert json.loads(bad.output)["failures"][0]["bound"] == "max_ate"
    assert len(list(cache.iterdir())) == 1                 # generated once, reused (cached by config hash)


def test_check_external_command_reading_the_dataset(cache, tmp_path):
    # a "perfect" external VO: copies the dataset's exact cam0 trajectory as its TUM output
    script = tmp_path / "perfect_vo.py"
    script.write_text("import shutil, sys\nshutil.copy(sys.argv[1] + '/groundtruth_tum.txt', sys.argv[2])\n")
    r = run_check("--estimator", f"cmd:{sys.executable} {script} {{dataset}} {{out}}", "--max-drift", "1e-6",
                  "--max-ate", "1e-6")
    assert r.exit_code == 0, r.output
    figures = json.loads(r.output)["figures"]
    assert figures["max_drift"] < 1e-6 and figures["max_ate"] < 1e-6


def test_check_unknown_bound_and_scenario(cache):
    r = CliRunner().invoke(cli, ["check", "--estimator", "klt-pnp", "--scenario", "nowhere"])
    assert r.exit_code != 0 and "unknown scenario 'nowhere'" in str(r.exception)
