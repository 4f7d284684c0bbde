"""Bad input gets exit code 2 and one line (or a correct result), never a traceback; see docs/bad_input.md.

Each case is run through the console entry point ``main`` as a user would type it. ``check``'s own
cases (no bound, negative bound, unwritable cache and --out, crashing program) are in test_check_gate.
"""
from __future__ import annotations

import json

import pytest

import vo.pipeline
from sim.app.cli import main
from sim.writers import EurocWriter
from test_dataset_synth import Synth


def vo_testbed(capsys, *args):
    """-> (exit code, stdout, stderr) of ``vo-testbed ARGS``."""
    code = 0
    try:
        main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_one_line_exit_2(code, err, needle):
    assert code == 2, err
    assert "Traceback" not in err and "Warning" not in err
    lines = [l for l in err.strip().splitlines() if l.strip()]
    assert any(needle in l for l in lines), err
    assert len([l for l in lines if l.startswith(("error:", "Error:"))]) == 1


@pytest.fixture(scope="module")
def synth(tmp_path_factory):
    root = tmp_path_factory.mktemp("bad_input")
    s = Synth(n_frames=5)
    s.write(EurocWriter(root / "ds", s.rig, s.metadata))
    return root


def gt_file(synth):
    return synth / "ds" / "groundtruth_tum.txt"


def tum_rows(synth):
    return [l for l in gt_file(synth).read_text().splitlines() if not l.startswith("#")]


def test_tum_with_nanosecond_timestamps_is_read_as_nanoseconds(synth, tmp_path, capsys, caplog):
    ns = tmp_path / "ns.txt"
    ns.write_text("".join(f"{int(r.split()[0].replace('.', ''))} {r.split(' ', 1)[1]}\n" for r in tum_rows(synth)))
    code, out, err = vo_testbed(capsys, "eval", "--gt", gt_file(synth), "--est", ns, "--json")
    assert code == 0, err
    res = json.loads(out)
    assert res["coverage"]["n_matched"] == 5 and res["ape"]["trans_m"]["max"] < 1e-9   # the same poses
    assert "read as nanoseconds" in caplog.text


def test_zero_quaternion(synth, tmp_path, capsys):
    bad = tmp_path / "zero_q.txt"
    rows = tum_rows(synth)
    rows[2] = " ".join(rows[2].split()[:4] + ["0", "0", "0", "0"])
    bad.write_text("\n".join(rows) + "\n")
    code, _, err = vo_testbed(capsys, "eval", "--gt", gt_file(synth), "--est", bad)
    assert_one_line_exit_2(code, err, "line 3: zero quaternion")


def test_empty_trajectory_file_no_numpy_warning(synth, tmp_path, capsys):
    empty = tmp_path / "empty.txt"
    empty.write_text("# nothing\n")
    with _no_warnings():
        code, _, err = vo_testbed(capsys, "eval", "--gt", gt_file(synth), "--est", empty)
    assert_one_line_exit_2(code, err, "no poses")


class _no_warnings:
    def __enter__(self):
        import warnings
        self._ctx = warnings.catch_warnings(record=True)
        self.caught = self._ctx.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc):
        self._ctx.__exit__(*exc)
        assert not self.caught, [str(w.message) for w in self.caught]


def test_out_in_an_unwritable_place(synth, tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    code, _, err = vo_testbed(capsys, "run", "--dataset", synth / "ds", "--estimator", "klt-pnp",
                              "--out", blocker / "out", "--no-progress")
    assert_one_line_exit_2(code, err, "cannot write output folder")
    code, _, err = vo_testbed(capsys, "eval", "--gt", gt_file(synth), "--est", gt_file(synth),
                              "--plot", blocker / "plots")
    assert_one_line_exit_2(code, err, "cannot write output folder")


@pytest.mark.parametrize("estimator, opt, needle", [
    ("rop", "disparity_offset={min_keyframes: 0}", "rop.disparity_offset.min_keyframes: must be >= 1"),
    ("klt-pnp", "disparity_offset={track_gate_px: -1}", "klt-pnp.disparity_offset.track_gate_px"),
])
def test_run_bad_estimator_option_leaves_no_output_folder(estimator, opt, needle, synth, tmp_path, capsys):
    code, _, err = vo_testbed(capsys, "run", "--dataset", synth / "ds", "--estimator", estimator, "--opt", opt,
                              "--out", tmp_path / "o", "--no-progress")
    assert_one_line_exit_2(code, err, needle)
    assert not (tmp_path / "o").exists()


def test_run_missing_dataset_folder_is_one_line(tmp_path, capsys):
    code, _, err = vo_testbed(capsys, "run", "--dataset", tmp_path / "nope", "--estimator", "rop",
                              "--out", tmp_path / "o")
    assert_one_line_exit_2(code, err, f"Invalid value for '--dataset': Path '{tmp_path / 'nope'}' does not exist")
    assert len(err.strip().splitlines()) == 1, err           # no usage block around it
    assert not (tmp_path / "o").exists()


def test_demo_unknown_estimator_refused_before_rendering(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "cache"))
    code, out, err = vo_testbed(capsys, "demo", "--scenario", "smoke", "--estimators", "klt-pnp,nosuch",
                                "--out", tmp_path / "demo", "--no-progress")
    assert_one_line_exit_2(code, err, "estimator 'nosuch' unknown")
    assert not (tmp_path / "cache").exists() and out == ""          # nothing generated, nothing printed


def test_demo_unwritable_cache(tmp_path, capsys, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    monkeypatch.setenv("VO_TESTBED_CACHE", str(blocker / "cache"))
    code, _, err = vo_testbed(capsys, "demo", "--scenario", "smoke", "--estimators", "klt-pnp",
                              "--out", tmp_path / "demo", "--no-progress")
    assert_one_line_exit_2(code, err, "VO_TESTBED_CACHE")


@pytest.mark.parametrize("args, needle", [
    (("--sigma-p", "-1"), "--sigma-p"),
    (("--sigma-p", "0"), "--sigma-p"),
    (("--sigma-p", "nan"), "--sigma-p"),
    (("--ranges", "5:1"), "--ranges"),
])
def test_predict_range_bad_values(args, needle, capsys):
    code, _, err = vo_testbed(capsys, "predict", "range", *args)
    assert_one_line_exit_2(code, err, needle)


def test_predict_cross_site_yaml_missing_fields(tmp_path, capsys):
    f = tmp_path / "layout.yaml"
    f.write_text("f_px: 1189.0\nbaseline_m: 0.27\nlandmarks: [[13, 1.5], [13, -1.5]]\n")
    code, _, err = vo_testbed(capsys, "predict", "cross-site", "--landmarks", f)
    assert_one_line_exit_2(code, err, "missing field(s) sigma_p_px, sigma_theta_px, previous_site, current_site")


def test_truncated_camera_csv_says_csv_and_folder_disagree(synth, tmp_path, capsys):
    import shutil
    ds = tmp_path / "ds"
    shutil.copytree(synth / "ds", ds)
    csv = ds / "mav0" / "cam0" / "data.csv"
    csv.write_text(csv.read_text()[:-12])                      # cut inside the last file name
    code, _, err = vo_testbed(capsys, "run", "--dataset", ds, "--estimator", "klt-pnp", "--out", tmp_path / "o")
    assert_one_line_exit_2(code, err, "disagree")
    assert "cam0/data.csv" in err


def test_unexpected_exception_is_exit_3_without_traceback(synth, tmp_path, capsys, monkeypatch):
    def boom(*a, **k):
        raise RuntimeError("planted bug")
    monkeypatch.setattr(vo.pipeline, "run_dataset", boom)
    code, _, err = vo_testbed(capsys, "run", "--dataset", synth / "ds", "--estimator", "klt-pnp",
                              "--out", tmp_path / "o")
    assert code == 3 and "internal error: RuntimeError: planted bug" in err and "Traceback" not in err


@pytest.mark.parametrize("args, needle", [
    (("--scene", "nosuch.mod:Scene"), "cannot import module 'nosuch.mod'"),
    (("--scene", "os:path"), "not a subclass of scenes.base.Scene"),
    (("--rig", "no/such/rig.yaml"), "no/such/rig.yaml"),
])
def test_generate_bad_plugin_scene_or_rig_path(args, needle, tmp_path, capsys):
    code, _, err = vo_testbed(capsys, "generate", *args, "--duration", "1", "--out", tmp_path / "ds")
    assert_one_line_exit_2(code, err, needle)
    assert not (tmp_path / "ds").exists()                       # refused before anything was written


def test_demo_estimator_failing_on_the_data_is_exit_2_after_the_others(tmp_path, capsys, monkeypatch):
    (tmp_path / "failing_vo.py").write_text(
        "from vo.estimators.base import Estimator\n"
        "class Failing(Estimator):\n"
        "    def process(self, frame):\n"
        "        raise ZeroDivisionError('no features')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "cache"))
    code, out, err = vo_testbed(capsys, "demo", "--scenario", "smoke", "--estimators", "klt-pnp,failing_vo:Failing",
                                "--max-frames", "5", "--out", tmp_path / "demo", "--no-progress")
    assert_one_line_exit_2(code, err, "1 estimator(s) failed: failing_vo:Failing")
    assert "=== klt-pnp (5 frames" in out and "raised ZeroDivisionError: no features" in out
