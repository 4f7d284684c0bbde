"""`vo-testbed check`, the CI gate: bounds, coverage, a sensor-only view for external programs, exit codes.

Exit codes (CONVENTIONS.md): 0 pass, 1 a bound exceeded or coverage too low, 2 bad input (including a
program that fails), 3 internal error. External programs here are small Python scripts; the "perfect"
ones copy the exact trajectory that the test put beside them (never from the folder they are handed).
"""
import hashlib
import json
import shutil
import sys
from pathlib import Path

import pytest

from sim.app.cli import main

GT_NAMES = ("groundtruth", "state_groundtruth", "poses", "gcps", "metadata", "depth", "segmentation")


@pytest.fixture
def cache(tmp_path_factory, monkeypatch):
    root = tmp_path_factory.getbasetemp() / "vo-cache"      # shared by the tests of this module
    monkeypatch.setenv("VO_TESTBED_CACHE", str(root))
    return root


def vo_testbed(capsys, *args):
    """Run the console entry point -> (exit code, stdout, stderr)."""
    code = 0
    try:
        main(list(args))
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def check(capsys, *args, scenario="smoke"):
    return vo_testbed(capsys, "check", "--scenario", scenario, "--no-progress", *args)


def dataset_of(scenario):
    from sim.app.check import scenario_dataset
    return scenario_dataset(scenario, progress=False)


def program(tmp_path, name, body):
    script = tmp_path / f"{name}.py"
    script.write_text("import os, shutil, sys\nds, out = sys.argv[1], sys.argv[2]\n" + body)
    return f"cmd:{sys.executable} {script} {{dataset}} {{out}}"


def answer(tmp_path, dataset) -> str:
    """The exact trajectory, copied beside the test's programs (their own folder, which they can read under any
    isolation; the cache is hidden from them)."""
    copy = tmp_path / "answer_tum.txt"
    shutil.copy(dataset / "groundtruth_tum.txt", copy)
    return str(copy)


def tree_digest(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_check_passes_and_fails_on_bounds(cache, capsys):
    code, out, _ = check(capsys, "--estimator", "klt-pnp", "--max-drift", "5.0", "--max-rpe", "0.05", "--json")
    assert code == 0, out
    res = json.loads(out)
    assert res["passed"] and res["figures"]["max_drift"] < 5.0
    assert res["coverage"]["n_matched"] == res["coverage"]["n_reference"] > 50      # every frame has a pose
    code, out, _ = check(capsys, "--estimator", "klt-pnp", "--max-ate", "1e-9", "--json")
    assert code == 1
    assert json.loads(out)["failures"][0]["bound"] == "max_ate"
    datasets = [p for p in cache.iterdir() if not p.name.startswith(".") and p.name not in ("textures", "worlds")]
    assert len(datasets) == 1                        # generated once, reused (+ its lock; textures, worlds kept beside)


def test_external_program_sees_sensor_data_only_and_cache_is_unchanged(cache, tmp_path, capsys):
    path = dataset_of("smoke")
    before = tree_digest(path)
    assert any("groundtruth" in k for k in before)         # the cache holds the truth ...
    spy = program(tmp_path, "spy", f"""
names = [os.path.relpath(os.path.join(r, f), ds) for r, _, fs in os.walk(ds) for f in fs]
found = [n for n in names if any(k in n for k in {GT_NAMES!r})]
if found:
    sys.exit("found ground truth: " + ", ".join(found))
assert any(n.endswith('.png') for n in names) and 'mav0/imu0/data.csv' in names and 'rig.yaml' in names
shutil.copy({answer(tmp_path, path)!r}, out)
""")
    code, out, err = check(capsys, "--estimator", spy, "--max-drift", "1e-6", "--max-ate", "1e-6")
    assert code == 0, out + err                            # ... the program saw none of it, and got a perfect run
    assert "PASSED" in out and "coverage" in out and "61 of 61" in out
    assert tree_digest(path) == before                      # byte-identical, no file added


def test_two_of_101_poses_fails_on_coverage(cache, tmp_path, capsys):
    path = dataset_of("campus-short")
    partial = program(tmp_path, "partial", f"""
lines = [l for l in open({answer(tmp_path, path)!r}) if not l.startswith('#')]
open(out, 'w').writelines(lines[:2])
print('wrote 2 poses', file=sys.stderr)
""")
    code, out, _ = check(capsys, "--estimator", partial, "--max-drift", "100", scenario="campus-short")
    assert code == 1
    assert "coverage: 2 of 101 frames matched" in out
    assert "wrote 2 poses" in out                          # the program's stderr is shown on failure
    # drift against the route's end, not the second pose: the 2 poses are exact, yet drift is ~100 %
    code, out, _ = check(capsys, "--estimator", partial, "--max-drift", "100", "--min-coverage", "0.01",
                         "--json", scenario="campus-short")
    res = json.loads(out)
    assert res["figures"]["max_ate"] < 1e-6 and res["figures"]["max_drift"] > 90


def test_nanosecond_tum_from_a_program_is_read_as_nanoseconds(cache, tmp_path, capsys, caplog):
    path = dataset_of("smoke")
    ns = program(tmp_path, "ns", f"""
with open(out, 'w') as f:
    for l in open({answer(tmp_path, path)!r}):
        if not l.startswith('#'):
            t, rest = l.split(' ', 1)
            s, frac = t.split('.')
            f.write(str(int(s) * 10**9 + int(frac)) + ' ' + rest)
""")
    code, out, err = check(capsys, "--estimator", ns, "--max-ate", "1e-6", "-v")
    assert code == 0, out + err
    assert "read as nanoseconds" in caplog.text             # said on the rigs.trajfile logger (stderr)


def test_no_bound_negative_bound_and_unknown_estimator_are_bad_input(cache, capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "empty-cache"))
    assert check(capsys, "--estimator", "klt-pnp")[0] == 2
    code, _, err = check(capsys, "--estimator", "klt-pnp", "--max-drift", "-1")
    assert code == 2 and "--max-drift" in err
    assert check(capsys, "--estimator", "klt-pnp", "--max-ate", "nan")[0] == 2
    assert check(capsys, "--estimator", "klt-pnp", "--max-ate", "1", "--min-coverage", "0")[0] == 2
    code, _, err = check(capsys, "--estimator", "nope", "--max-ate", "1")
    assert code == 2 and "unknown" in err and "Traceback" not in err
    assert not (tmp_path / "empty-cache").exists()          # refused before anything was generated


def test_crashing_program_exits_2_with_its_stderr(cache, tmp_path, capsys):
    crash = program(tmp_path, "crash", "print('segfault in tracker', file=sys.stderr)\nsys.exit(3)\n")
    code, out, err = check(capsys, "--estimator", crash, "--max-ate", "1")
    assert code == 2 and "FAILED" not in out                # a crash is not an accuracy failure
    assert "segfault in tracker" in err and "exit code 3" in err


def test_unwritable_cache_and_out_are_one_line_errors(tmp_path, capsys, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    monkeypatch.setenv("VO_TESTBED_CACHE", str(blocker / "cache"))
    code, _, err = check(capsys, "--estimator", "klt-pnp", "--max-ate", "1")
    assert code == 2 and "VO_TESTBED_CACHE" in err and len(err.strip().splitlines()) == 1
    code, _, err = check(capsys, "--estimator", "klt-pnp", "--max-ate", "1", "--out", str(blocker / "out"))
    assert code == 2 and "cannot write output folder" in err and len(err.strip().splitlines()) == 1


def test_one_pose_never_passes(cache, tmp_path, capsys):
    path = dataset_of("smoke")
    one = program(tmp_path, "one", f"""
first = next(l for l in open({answer(tmp_path, path)!r}) if not l.startswith('#'))
open(out, 'w').write(first)
""")
    code, out, _ = check(capsys, "--estimator", one, "--max-ate", "1", "--min-coverage", "0.01")
    assert code == 1 and "1 of 61 frames matched an estimated pose; at least 2 are needed" in out
