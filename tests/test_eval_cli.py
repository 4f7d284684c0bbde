"""``vo-testbed eval``: table, JSON with the library's numbers, plots, GCP csv, and errors."""
import json
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from sim.app.cli import cli, main
from vo.eval import evaluate
from rigs.geometry import make_T, so3_exp
from rigs.trajectory import Trajectory
from rigs.trajfile import read_tum, write_tum


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    rng = np.random.default_rng(3)
    n = 120
    t_ns = np.arange(n, dtype=np.int64) * 100_000_000
    T_gt = np.array([make_T(so3_exp([0, 0, 0.02 * k]), [0.5 * k, 2 * np.sin(0.05 * k), 0]) for k in range(n)])
    T_est = T_gt.copy()
    T_est[:, :3, 3] += np.cumsum(rng.normal(0, 0.01, (n, 3)), axis=0)           # random-walk drift
    d = tmp_path_factory.mktemp("cli")
    write_tum(d / "gt.txt", Trajectory(t_ns, T_gt))
    write_tum(d / "est.txt", Trajectory(t_ns, T_est))
    with open(d / "gcps.csv", "w") as f:
        f.write("#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z\n")
        for name, k in (("G1", 30), ("G2", 90)):
            p = T_gt[k, :3, 3]
            f.write(f"{name},{t_ns[k]},{p[0]},{p[1]},0.0,{p[0]},{p[1]},{p[2]}\n")
    return d


def test_eval_cli_table_and_json_same_numbers(files):
    args = ["eval", "--gt", str(files / "gt.txt"), "--est", str(files / "est.txt"), "--align", "se3"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    lib = evaluate(read_tum(files / "gt.txt"), read_tum(files / "est.txt"), align="se3")
    assert f"rmse {lib.ape.trans.rmse:.4f}" in res.output and "KITTI" in res.output
    res_j = CliRunner().invoke(cli, args + ["--json"])
    assert res_j.exit_code == 0, res_j.output
    d = json.loads(res_j.stdout)                  # stderr says what was compared
    assert d["ape"]["trans_m"]["rmse"] == pytest.approx(lib.ape.trans.rmse, rel=1e-12)
    assert d["rpe_frame"]["trans_m"]["mean"] == pytest.approx(lib.rpe_frame.trans.mean, rel=1e-12)
    assert d["drift"]["drift_ratio_pct"] == pytest.approx(lib.drift.drift_ratio_pct, rel=1e-12)
    assert d["alignment"]["method"] == "se3" and d["n_matched"] == 120


def test_eval_cli_gcps_and_plots(files, tmp_path):
    args = ["eval", "--gt", str(files / "gt.txt"), "--est", str(files / "est.txt"),
            "--gcps", str(files / "gcps.csv"), "--plot", str(tmp_path / "plots")]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert "G2" in res.output and "Drift ratio (%)" in res.output
    for name in ("topdown.png", "error_vs_distance.png", "rpe.png"):
        f = tmp_path / "plots" / name
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list((tmp_path / "plots").glob("*.part"))


def test_eval_missing_file_exit_2_one_line(files, tmp_path, monkeypatch, capsys):
    missing = tmp_path / "nope.txt"
    monkeypatch.setattr(sys, "argv", ["vo-testbed", "eval", "--gt", str(missing), "--est", str(files / "est.txt")])
    with pytest.raises(SystemExit) as exc:
        main()
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and str(missing) in err and "\n" not in err


def test_eval_cli_kitti_files_and_short_route_strict_json(tmp_path):
    from rigs.trajfile import write_kitti
    n = 3                                                     # standing still: drift ratio, KITTI NaN -> null
    T = np.tile(np.eye(4), (n, 1, 1))
    traj = Trajectory(np.arange(n, dtype=np.int64) * 100_000_000, T)
    write_kitti(tmp_path / "gt.txt", traj, times_path=tmp_path / "times.txt")   # one times.txt beside both
    write_kitti(tmp_path / "est.txt", traj)
    res = CliRunner().invoke(cli, ["eval", "--gt", str(tmp_path / "gt.txt"), "--est", str(tmp_path / "est.txt"),
                                   "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert d["n_matched"] == 3 and d["ape"]["trans_m"]["rmse"] == 0.0
    assert d["drift"]["drift_ratio_pct"] is None and d["kitti"]["t_err_pct"] is None


def test_eval_cli_does_not_import_mujoco():
    import subprocess
    code = ("import sys; from sim.app.cli import cmd_eval; import vo.eval.plots; "
            "sys.exit(1 if 'mujoco' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], timeout=120).returncode == 0
