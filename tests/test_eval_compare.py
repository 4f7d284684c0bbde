"""``eval`` with several ``--est`` (one table, one plot), ``--save-results`` (evo's result zip, read by the
real ``evo_res``), and the alignment with eval's default stated in every table header."""
import csv
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from rigs.geometry import make_T, so3_exp
from sim.app.cli import cli
from vo.eval import evaluate
from rigs.trajectory import Trajectory
from rigs.trajfile import read_tum, write_tum

EVO_RES = Path(sys.executable).parent / "evo_res"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    rng = np.random.default_rng(5)
    n = 120
    t_ns = np.arange(n, dtype=np.int64) * 100_000_000
    T_gt = np.array([make_T(so3_exp([0, 0, 0.02 * k]), [0.5 * k, 2 * np.sin(0.05 * k), 0]) for k in range(n)])
    d = tmp_path_factory.mktemp("cmp")
    write_tum(d / "gt.txt", Trajectory(t_ns, T_gt))
    for name, sigma in (("small.txt", 0.01), ("large.txt", 0.03)):
        T = T_gt.copy()
        T[:, :3, 3] += np.cumsum(rng.normal(0, sigma, (n, 3)), axis=0)           # random-walk drift
        write_tum(d / name, Trajectory(t_ns, T))
    return d


def _lib(files, name, align):
    return evaluate(read_tum(files / "gt.txt"), read_tum(files / name), align=align)


def test_several_estimates_one_table_one_plot(files, tmp_path):
    args = ["eval", "--gt", str(files / "gt.txt"), "--est", str(files / "small.txt"), "--est",
            str(files / "large.txt"), "--align", "se3", "--plot", str(tmp_path / "p")]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if not ln.startswith("estimate: ")]   # stderr notes aside
    assert lines[0] == "alignment: se3 (default: first): Umeyama SE(3) on the matched positions"
    for name in ("small.txt", "large.txt"):
        lib = _lib(files, name, "se3")
        row = next(ln for ln in lines if ln.startswith(name)).split()
        assert int(row[1]) == 120
        assert float(row[2]) == pytest.approx(lib.ape.trans.rmse, abs=5e-5)
        assert float(row[4]) == pytest.approx(lib.rpe_frame.trans.rmse, abs=5e-5)
        assert float(row[6]) == pytest.approx(lib.drift.drift_ratio_pct, abs=5e-3)
    assert (tmp_path / "p/comparison.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = CliRunner().invoke(cli, args + ["--json"]).output
    d = json.loads(out[out.index("{"):])
    assert d["alignment"] == "se3"
    assert d["estimates"]["large.txt"]["ape"]["trans_m"]["rmse"] == pytest.approx(
        _lib(files, "large.txt", "se3").ape.trans.rmse, rel=1e-12)


@pytest.mark.parametrize("align, header", [
    ("first", "alignment           first (the default): first estimated pose put on the first ground-truth pose"),
    ("sim3", "alignment           sim3 (default: first): Umeyama Sim(3) on the matched positions, scale "),
])
def test_single_table_header_states_alignment_and_default(files, align, header):
    res = CliRunner().invoke(cli, ["eval", "--gt", str(files / "gt.txt"), "--est", str(files / "small.txt"),
                                   "--align", align])
    assert res.exit_code == 0, res.output
    table = [ln for ln in res.output.splitlines() if not ln.startswith("estimate: ")]   # stderr notes aside
    assert table[0].startswith(header)


@pytest.mark.slow
def test_saved_results_are_read_by_evo_res(files, tmp_path):
    # One zip per estimate; the real evo_res reads them and its table holds our ATE statistics.
    assert EVO_RES.is_file(), "evo (the test extra) provides evo_res"
    args = ["eval", "--gt", str(files / "gt.txt"), "--est", str(files / "small.txt"), "--est",
            str(files / "large.txt"), "--align", "se3", "--save-results", str(tmp_path / "res.zip")]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    zips = [tmp_path / "res.small.zip", tmp_path / "res.large.zip"]
    assert all(f"results (evo): {z}" in res.output for z in zips)
    one = CliRunner().invoke(cli, ["eval", "--gt", str(files / "gt.txt"), "--est", str(files / "small.txt"),
                                   "--align", "se3", "--save-results", str(tmp_path / "one.zip")])
    assert one.exit_code == 0 and (tmp_path / "one.zip").is_file(), one.output
    env = {**os.environ, "HOME": str(tmp_path), "MPLBACKEND": "Agg"}     # evo's default settings
    r = subprocess.run([str(EVO_RES), *map(str, zips), str(tmp_path / "one.zip"), "--use_filenames",
                        "--save_table", str(tmp_path / "t.csv"), "--no_warnings"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr + r.stdout
    rows = {row[""]: row for row in csv.DictReader((tmp_path / "t.csv").open())}
    for z, name in ((zips[0], "small.txt"), (zips[1], "large.txt"), (tmp_path / "one.zip", "small.txt")):
        lib = _lib(files, name, "se3").ape.trans
        row = rows[str(z)]
        for key in ("rmse", "mean", "median", "std", "min", "max"):
            assert float(row[key]) == pytest.approx(getattr(lib, key), rel=1e-12), (z, key)
