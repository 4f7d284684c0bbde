"""``vo-testbed localize`` on a tiny rendered traverse (3 sites, 2 pan pairs): the TUM output has the
ground truth's site times and site 0 at its true pose; a site whose images carry no texture (no
overlap) keeps its dead-reckoning prior and the next site is still processed; bad input exits 2
with one line."""
import json
import shutil

import cv2
import numpy as np
import pytest

from rigs.geometry import inv_T
from sim.app.cli import main
from rigs.trajfile import read_tum


class _Result:
    def __init__(self, code, out, err):
        self.exit_code, self.output, self.err = code, out, err


def _cli(*args, capsys=None):
    """Run the console entry point; -> exit code, stdout, stderr (with ``capsys``)."""
    try:
        main(list(args))
        code = 0
    except SystemExit as e:
        code = e.code or 0
    out, err = capsys.readouterr() if capsys is not None else ("", "")
    return _Result(code, out, err)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("trav") / "ds"
    r = _cli("generate", "--scenario", "yutu-traverse", "--out", str(out), "--no-progress",
             "--set", "traverse.max_sites=3", "--set", "traverse.n_pairs=2")
    assert r.exit_code == 0, r.output
    return out


@pytest.mark.long
def test_localize_writes_site_poses_at_the_truth_times(tiny, tmp_path, capsys):
    capsys.readouterr()
    r = _cli("localize", "--dataset", str(tiny), "--out", str(tmp_path / "loc"), "--json", capsys=capsys)
    assert r.exit_code == 0, r.output
    s = json.loads(r.output)
    gt, est = read_tum(tiny / "sites" / "groundtruth_tum.txt"), read_tum(tmp_path / "loc" / "site_poses_tum.txt")
    assert np.array_equal(gt.t_ns, est.t_ns) and len(est.t_ns) >= 3
    assert np.allclose(est.T[0], gt.T[0], atol=1e-6)            # site 0 taken as known
    assert [row["site"] for row in s["sites"]] == list(range(len(gt.t_ns)))
    assert all(row["status"] in ("known", "ok", "no_tie_points", "few_tie_points", "ambiguous") for row in s["sites"])
    assert (tmp_path / "loc" / "traverse_map.png").stat().st_size > 0


@pytest.mark.long
def test_textureless_site_keeps_the_prior_and_the_next_is_processed(tiny, tmp_path, capsys):
    """Site 1's images replaced by a flat grey: no ASIFT feature, so ``no_tie_points``; its pose is the
    dead-reckoning prior (moved by site 0's correction, none here: site 0 is the truth, and the
    writer starts the dead reckoning at the truth)."""
    ds = tmp_path / "ds"
    shutil.copytree(tiny, ds)
    for f in (ds / "sites" / "site_01").glob("pair_*.png"):
        img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
        cv2.imwrite(str(f), np.full_like(img, 90))
    capsys.readouterr()
    r = _cli("localize", "--dataset", str(ds), "--out", str(tmp_path / "loc"), "--json", capsys=capsys)
    assert r.exit_code == 0, r.output
    rows = json.loads(r.output)["sites"]
    assert rows[1]["status"] == "no_tie_points" and rows[2]["status"] in ("ok", "no_tie_points", "few_tie_points", "ambiguous")
    est = read_tum(tmp_path / "loc" / "site_poses_tum.txt")
    dr = read_tum(ds / "sites" / "dead_reckoning_tum.txt")
    T0 = read_tum(ds / "sites" / "groundtruth_tum.txt").T[0]
    expect = T0 @ inv_T(dr.T[0]) @ dr.T[1]
    assert np.allclose(est.T[1], expect, atol=1e-6) and np.all(np.isfinite(est.T))


def test_missing_dataset_exits_2_with_one_line(tmp_path, capsys):
    r = _cli("localize", "--dataset", str(tmp_path / "nope"), "--out", str(tmp_path / "o"), capsys=capsys)
    assert r.exit_code == 2 and r.err.strip().count("\n") == 0 and "nope" in r.err, r.err


def test_not_a_traverse_exits_2_with_one_line(tmp_path, capsys):
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "metadata.yaml").write_text("kind: euroc\n")
    r = _cli("localize", "--dataset", str(tmp_path / "ds"), "--out", str(tmp_path / "o"), capsys=capsys)
    assert r.exit_code == 2 and r.err.strip().count("\n") == 0 and "traverse" in r.err, r.err


def test_bad_set_field_exits_2(tmp_path, capsys):
    (tmp_path / "ds").mkdir()
    r = _cli("localize", "--dataset", str(tmp_path / "ds"), "--out", str(tmp_path / "o"), "--set", "bogus=1",
             capsys=capsys)
    assert r.exit_code == 2 and "bogus" in r.err, r.err
