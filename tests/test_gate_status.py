"""The gate counts only real estimates; evaluation says what it compared.

Frames have a class (ok, coasting, init, lost): only produced poses (ok, coasting) are covered and scored,
in memory (``check``, ``run``) and from files (``eval`` reads the run's ``frames.csv`` and ``times.txt``).
Bounds that can never fail are refused; a constant time offset is found and suggested; progress shows in
logs; OpenCV's global RNG is seeded per run.
"""
import io
import json

import cv2
import numpy as np
import pytest

from rigs.geometry import make_T, rot_z
from sim.app.check import validate_bounds
from sim.app.cli import main
from sim.errors import SimError
from vo.errors import VoError
from vo.estimators.base import Estimator, FrameResult
from vo.estimators.progress import progress_iter, progress_lines
from vo.estimators.runner import run_estimator
from vo.eval import evaluate
from rigs.trajectory import Trajectory
from rigs.trajfile import write_kitti, write_tum

from test_estimators_pnp import make_rig  # noqa: E402  (tests/ is on sys.path under pytest's rootdir)
from test_estimators_registry import FakeDataset  # noqa: E402

N = 40                      # frames of the synthetic runs
DT_NS = 50_000_000          # 20 Hz
T0_NS = 1_000_000_000       # the data's clock starts at 1 s (FakeDataset)


def true_pose(k):
    """T_w_c0 of frame k: 0.1 m along x per frame on a slow left turn."""
    return make_T(rot_z(np.radians(0.5 * k)), [0.1 * k, 0.002 * k * k, 0.0])


def gt_trajectory(n=N):
    return Trajectory(T0_NS + np.arange(n, dtype=np.int64) * DT_NS, np.array([true_pose(k) for k in range(n)]))


class PlaceholderEstimator(Estimator):
    """Frames 0-4 placeholders (init, identity); from frame 5, where it initialises, the pose relative to
    frame 5 (its origin) with 0.2 mm error per frame along each axis; frames 20-22 fail: 20-21 extrapolated
    (coasting), 22 held (lost). A plug-in that states its pose classes."""

    name = "placeholder"

    def __init__(self, rig, **options):
        super().__init__(rig, **options)
        self.k = 0

    def pose(self, k):
        T = np.linalg.inv(true_pose(5)) @ true_pose(k)
        T[:3, 3] += 0.0002 * (k - 5)
        return T

    def process(self, frame):
        k, self.k = self.k, self.k + 1
        if k < 5:
            return FrameResult(frame.t_ns, np.eye(4), "init", message="collecting keyframes")
        if k in (20, 21):
            return FrameResult(frame.t_ns, self.pose(k), "lost", pose_class="coasting")
        if k == 22:
            return FrameResult(frame.t_ns, self.pose(21), "lost", pose_class="lost")
        return FrameResult(frame.t_ns, self.pose(k), "ok")


class NeverInitialises(Estimator):
    name = "never"

    def process(self, frame):
        return FrameResult(frame.t_ns, np.eye(4), "init", message="collecting keyframes 1/10")


class RngEstimator(Estimator):
    """Its poses depend on OpenCV's global RNG (as RANSAC's draws may): one cv2.randu draw per frame."""

    name = "rng"

    def process(self, frame):
        draw = np.zeros((1, 3))
        cv2.randu(draw, 0.0, 1.0)
        return FrameResult(frame.t_ns, make_T(np.eye(3), draw.ravel()), "ok")


@pytest.fixture
def cache(tmp_path_factory, monkeypatch):
    root = tmp_path_factory.getbasetemp() / "gate-cache"     # smoke generated once for this module's tests
    monkeypatch.setenv("VO_TESTBED_CACHE", str(root))
    return root


def vo_testbed(capsys, *args):
    code = 0
    try:
        main(list(args))
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


# ---------------------------------------------------------------------------------------------- classes
def test_placeholders_are_not_covered_nor_scored():
    run = run_estimator("test_gate_status:PlaceholderEstimator", FakeDataset(make_rig(), n=N), progress=False)
    assert run.class_counts() == {"ok": 32, "coasting": 2, "init": 5, "lost": 1}
    gt = gt_trajectory()
    ev = evaluate(gt, run.trajectory, pose_classes=run.pose_classes(), align="first")
    produced = [k for k in range(N) if k >= 5 and k != 22]
    assert ev.coverage.n_matched == len(produced) == 34 and ev.coverage.n_reference == N
    assert ev.frames_by_status == run.class_counts()
    # the scored poses are exactly the produced ones: same figures as evaluating that subset alone
    alone = evaluate(gt, run.trajectory.subset(np.array(produced)), align="first")
    assert ev.ape.trans.rmse == alone.ape.trans.rmse and ev.drift.end_diff_m == alone.drift.end_diff_m
    # anchored at frame 5, its first estimated pose, the error is the 0.2 mm per frame it was given
    expected = np.sqrt(np.mean([3 * (0.0002 * (k - 5)) ** 2 for k in produced]))
    assert ev.ape.trans.rmse == pytest.approx(expected, rel=1e-9)
    # counted naively, the identity placeholders are scored and anchor the estimate at frame 0: every
    # later pose then sits 0.5 m (frame 5's distance from the start) off
    naive = evaluate(gt, run.trajectory, align="first")
    assert naive.coverage.n_matched == N and naive.ape.trans.rmse > 0.4 > 20 * ev.ape.trans.rmse
    assert "frames by status    ok 32, coasting 2, init 5, lost 1" in ev.table()
    assert ev.to_dict()["frames_by_status"] == run.class_counts()


def test_evaluate_refuses_an_estimate_without_estimated_poses():
    run = run_estimator("test_gate_status:NeverInitialises", FakeDataset(make_rig(), n=6), progress=False)
    with pytest.raises(VoError, match=r"no estimated pose \(ok 0, coasting 0, init 6, lost 0\): "
                                      r"the estimator never initialised"):
        evaluate(gt_trajectory(6), run.trajectory, pose_classes=run.pose_classes())


@pytest.mark.slow
def test_check_fails_vins_that_never_initialises_on_smoke(cache, capsys):
    """The issue's case: on smoke (3 s) vins never leaves initialisation; every frame is an identity
    placeholder. Counted as poses, the gate passed with 100 % coverage; now it fails, saying why."""
    code, out, err = vo_testbed(capsys, "check", "--estimator", "vins", "--scenario", "smoke", "--max-ate", "0.5",
                                "--no-progress", "--json")
    assert code == 1, (out, err)
    res = json.loads(out)
    assert res["frames_by_status"] == {"ok": 0, "coasting": 0, "init": 61, "lost": 0}
    assert res["coverage"]["n_matched"] == 0 and not res["passed"]
    assert res["failures"][0]["message"] == ("vins never initialised: none of its 61 frames has an estimated "
                                             "pose (ok 0, coasting 0, init 61, lost 0)")
    code, out, _ = vo_testbed(capsys, "check", "--estimator", "vins", "--scenario", "smoke", "--max-ate", "0.5",
                              "--no-progress")
    assert code == 1
    assert "frames by status                       ok 0, coasting 0, init 61, lost 0" in out
    assert "FAILED: vins never initialised" in out and "PASSED" not in out


@pytest.mark.parametrize("flag, value, message", [
    ("--max-ate", "inf", "inf is a bound that can never fail"),
    ("--max-drift", "nan", "must be a finite number >= 0, got nan"),
    ("--max-rpe", "-inf", "must be a finite number >= 0, got -inf"),
])
def test_check_refuses_a_bound_that_cannot_fail(tmp_path, monkeypatch, capsys, flag, value, message):
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "cache"))
    code, _, err = vo_testbed(capsys, "check", "--estimator", "klt-pnp", "--scenario", "smoke", flag, value)
    assert code == 2 and message in err and "Traceback" not in err
    assert not (tmp_path / "cache").exists()                # refused before anything is generated


def test_bounds_library_level():
    assert validate_bounds({"max_drift": 1e300}, 0.95) == {"max_drift": 1e300}      # huge but finite: fine
    with pytest.raises(SimError, match="max_ate: inf is a bound that can never fail"):
        validate_bounds({"max_ate": float("inf")}, 0.95)
    with pytest.raises(SimError, match="max_rpe: must be a finite number >= 0, got nan"):
        validate_bounds({"max_rpe": float("nan")}, 0.95)


# ------------------------------------------------------------------------------------- eval from files
@pytest.fixture
def run_dir(tmp_path):
    """A saved run of PlaceholderEstimator (trajectory_tum/kitti, times.txt, frames.csv) and the truth."""
    run = run_estimator("test_gate_status:PlaceholderEstimator", FakeDataset(make_rig(), n=N), progress=False)
    run.save(tmp_path / "run")
    write_tum(tmp_path / "gt.txt", gt_trajectory())
    return tmp_path, run


def eval_json(capsys, *args):
    code, out, err = vo_testbed(capsys, "eval", *args, "--json")
    return code, (json.loads(out) if code == 0 else None), err


def test_eval_from_files_reads_times_and_frame_status(run_dir, capsys):
    d, run = run_dir
    in_memory = evaluate(gt_trajectory(), run.trajectory, pose_classes=run.pose_classes())
    for est in ("trajectory_kitti.txt", "trajectory_tum.txt"):
        code, res, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(d / "run" / est))
        assert code == 0, err
        assert res["frames_by_status"] == {"ok": 32, "coasting": 2, "init": 5, "lost": 1}
        assert res["coverage"]["n_matched"] == 34
        assert res["ape"]["trans_m"]["rmse"] == pytest.approx(in_memory.ape.trans.rmse, abs=1e-8)   # 9 decimals
        assert f"frame status: {d / 'run' / 'frames.csv'} (ok 32, coasting 2, init 5, lost 1)" in err
        assert res["warnings"] == []
        assert (f"times from {d / 'run' / 'times.txt'}" in err) == (est == "trajectory_kitti.txt")


def test_eval_kitti_never_assumes_a_rate(run_dir, tmp_path, capsys):
    d, _ = run_dir
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "est.txt").write_text((d / "run" / "trajectory_kitti.txt").read_text())
    code, _, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(lone / "est.txt"))
    assert code == 2 and "KITTI poses hold no timestamps and there is no times.txt beside them" in err
    assert "--times FILE" in err and len(err.strip().splitlines()) == 1
    code, res, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(lone / "est.txt"),
                               "--times", str(d / "run" / "times.txt"))
    assert code == 0, err
    # no frame log beside it: every pose counts, placeholders included (the counts say so)
    assert res["frames_by_status"] == {"ok": N, "coasting": 0, "init": 0, "lost": 0}
    assert res["coverage"]["n_matched"] == N
    code, _, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(d / "run" / "trajectory_tum.txt"),
                             "--times", str(d / "run" / "times.txt"))
    assert code == 2 and "a times file applies to KITTI poses only" in err


def test_eval_frame_log_of_another_run_is_refused(run_dir, capsys):
    d, _ = run_dir
    rows = (d / "run" / "frames.csv").read_text().splitlines()
    (d / "other.csv").write_text("\n".join(rows[:10]) + "\n")
    code, _, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(d / "run" / "trajectory_tum.txt"),
                             "--frames", str(d / "other.csv"))
    assert code == 2 and "the frame log has no row for 31 of the 40 poses" in err


def shifted_copy(d, shift_s):
    """The run's TUM estimate with every timestamp plus ``shift_s`` (a folder without a frame log)."""
    from rigs.trajfile import read_tum
    est = read_tum(d / "run" / "trajectory_tum.txt")
    keep = np.arange(5, N)                                   # the produced poses, so every pose counts
    keep = keep[keep != 22]
    out = d / f"shift_{shift_s}"
    out.mkdir()
    write_tum(out / "est.txt", Trajectory(est.t_ns[keep] + int(shift_s * 1e9), est.T[keep]))
    return out / "est.txt"


def test_eval_time_offset_found_and_applied(run_dir, capsys):
    d, _ = run_dir
    base = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(shifted_copy(d, 0.0)))[1]
    assert base["warnings"] == []                               # the right clock: nothing to suggest
    est = shifted_copy(d, 0.5)                                  # 10 frames late
    code, res, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(est))
    assert code == 0, err
    hint = [w for w in res["warnings"] if "constant time offset" in w]
    assert len(hint) == 1 and "with --t-offset -0.5 " in hint[0], res["warnings"]
    assert res["ape"]["trans_m"]["rmse"] > 10 * base["ape"]["trans_m"]["rmse"]
    code, res, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(est), "--t-offset", "-0.5")
    assert code == 0 and res["warnings"] == [] and res["t_offset_s"] == -0.5
    assert res["ape"]["trans_m"]["rmse"] == pytest.approx(base["ape"]["trans_m"]["rmse"], abs=1e-12)
    # 100 s late: not one pose associates; the error says which offset would
    code, _, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(shifted_copy(d, 100.0)))
    assert code == 2 and "only 0 of 40 ground-truth poses matched" in err and "--t-offset -100 " in err
    code, _, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(est), "--t-offset", "nan")
    assert code == 2 and "'--t-offset': must be a finite number" in err


def test_eval_warns_when_fewer_than_half_associate(run_dir, capsys):
    d, _ = run_dir
    est = shifted_copy(d, 0.0)
    gt = gt_trajectory()
    write_tum(d / "gt_short.txt", gt.subset(np.arange(N) < 15))     # truth for 10 of the 34 estimated poses
    code, res, err = eval_json(capsys, "--gt", str(d / "gt_short.txt"), "--est", str(est))
    assert code == 0, err
    assert any(w.startswith("only 10 of 34 estimated poses matched a ground-truth pose within 10 ms")
               for w in res["warnings"]), res["warnings"]


# ------------------------------------------------------------------------------------ newcomer's list
@pytest.mark.parametrize("value", ["0", "nan", "-3", "inf"])
def test_eval_refuses_rpe_delta_that_drops_rows(run_dir, capsys, value):
    d, _ = run_dir
    code, _, err = vo_testbed(capsys, "eval", "--gt", str(d / "gt.txt"), "--est",
                              str(d / "run" / "trajectory_tum.txt"), f"--rpe-delta-m={value}")
    assert code == 2 and "Invalid value for '--rpe-delta-m': must be a finite number > 0" in err
    with pytest.raises(VoError, match="rpe_delta_m: must be a finite number > 0"):
        evaluate(gt_trajectory(), gt_trajectory(), rpe_delta_m=float(value))


def test_eval_names_the_column_count(run_dir, capsys):
    d, _ = run_dir
    rows = (d / "run" / "trajectory_kitti.txt").read_text().splitlines()
    (d / "run" / "eleven.txt").write_text("\n".join(" ".join(r.split()[:11]) for r in rows) + "\n")
    code, _, err = vo_testbed(capsys, "eval", "--gt", str(d / "gt.txt"), "--est", str(d / "run" / "eleven.txt"))
    assert code == 2
    assert err.strip() == (f"error: {d / 'run' / 'eleven.txt'}: 11 values per line; a trajectory has 8 (TUM: "
                           f"t tx ty tz qx qy qz qw) or 12 (KITTI: the 3x4 pose, row-major); give --format for "
                           f"another layout")
    # 12 columns without --format: read as KITTI (with the times.txt beside it), not as TUM
    code, res, err = eval_json(capsys, "--gt", str(d / "gt.txt"), "--est", str(d / "run" / "trajectory_kitti.txt"))
    assert code == 0 and res["coverage"]["n_matched"] == 34
    code, _, err = vo_testbed(capsys, "eval", "--gt", str(d / "gt.txt"), "--est",
                              str(d / "run" / "trajectory_kitti.txt"), "--format", "tum")
    assert code == 2 and "duplicate timestamps (12 values per line where the format has 8; KITTI poses have 12" in err


def test_progress_lines_when_not_a_terminal(capsys):
    buf = io.StringIO()                                           # not a tty
    assert list(progress_iter(range(61), 61, True, "klt-pnp", stream=buf)) == list(range(61))
    lines = buf.getvalue().splitlines()
    assert [ln.split(" frames")[0] for ln in lines] == [f"klt-pnp: {k}/61" for k in (7, 13, 19, 25, 31, 37, 43, 49,
                                                                                     55, 61)]
    assert lines[-1].startswith("klt-pnp: 61/61 frames (100 %), ") and "\r" not in buf.getvalue()
    assert list(progress_lines(range(3), 3, "x", buf, step_pct=50)) == [0, 1, 2]
    # a run writes them to stderr (not a terminal under pytest); a disabled report writes nothing
    run_estimator("test_gate_status:PlaceholderEstimator", FakeDataset(make_rig(), n=N), progress=True)
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 10 and err[-1].startswith("placeholder: 40/40 frames (100 %)")
    run_estimator("test_gate_status:PlaceholderEstimator", FakeDataset(make_rig(), n=N), progress=False)
    assert capsys.readouterr().err == ""


def test_progress_bar_on_a_terminal():
    class Tty(io.StringIO):
        def isatty(self):
            return True
    buf = Tty()
    assert list(progress_iter(range(20), 20, True, "rop", stream=buf)) == list(range(20))
    assert "\r" in buf.getvalue() and "20/20" in buf.getvalue()          # tqdm's redrawn bar


# ------------------------------------------------------------------------------------------ determinism
def test_opencv_rng_seeded_per_run():
    """Two runs in one process give identical trajectories although another estimator drew from OpenCV's
    global RNG in between; another seed gives another trajectory (so the RNG really is used)."""
    ds = FakeDataset(make_rig(), n=5)
    a = run_estimator("test_gate_status:RngEstimator", ds, progress=False).trajectory
    run_estimator("test_gate_status:RngEstimator", ds, progress=False, seed=9)
    cv2.randu(np.zeros((50, 50)), 0, 1)
    b = run_estimator("test_gate_status:RngEstimator", ds, progress=False).trajectory
    assert np.array_equal(a.T, b.T)
    c = run_estimator("test_gate_status:RngEstimator", ds, progress=False, seed=1).trajectory
    assert not np.allclose(a.T, c.T)


@pytest.mark.slow
def test_klt_pnp_identical_after_another_estimator(cache):
    """klt-pnp twice on smoke in one process, orb-pnp and a foreign RNG draw in between: same bytes."""
    from sim.app.check import scenario_dataset
    from vo.dataset import open_dataset
    ds = open_dataset(scenario_dataset("smoke", progress=False))
    first = run_estimator("klt-pnp", ds, progress=False, max_frames=12).trajectory
    run_estimator("orb-pnp", ds, progress=False, max_frames=12, seed=5)
    cv2.setRNGSeed(77)
    cv2.randu(np.zeros((50, 50)), 0, 1)
    again = run_estimator("klt-pnp", ds, progress=False, max_frames=12).trajectory
    assert np.array_equal(first.T, again.T) and np.array_equal(first.t_ns, again.t_ns)
