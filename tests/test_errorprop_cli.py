"""`vo-testbed predict` prints the models' figures and writes plots; bad ranges fail in one line."""
import json

import pytest
from click.testing import CliRunner

from sim.app.cli import cli
from vo.errorprop import range_sigma
from vo.errorprop.predict import parse_ranges
from vo.errors import VoError


def test_predict_range_json_matches_eq7(tmp_path):
    r = CliRunner().invoke(cli, ["predict", "range", "--rig", "stereo27", "--ranges", "5,10", "--json",
                                 "--plot", str(tmp_path / "r.png")])
    assert r.exit_code == 0, r.output
    rows = json.loads(r.output)["rows"]
    assert rows[1]["sigma_eq7_m"] == pytest.approx(float(range_sigma(10.0, 0.27, 458.0, 1 / 3)), rel=1e-12)
    assert (tmp_path / "r.png").stat().st_size > 1000


def test_predict_range_baseline_override_scales_inversely():
    r = CliRunner().invoke(cli, ["predict", "range", "--rig", "stereo27", "--set", "baseline=0.135",
                                 "--ranges", "10", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["rows"][0]["sigma_eq7_m"] == pytest.approx(2 * float(range_sigma(10, 0.27, 458, 1 / 3)))


def test_predict_cross_site_cli(tmp_path):
    r = CliRunner().invoke(cli, ["predict", "cross-site", "--preset", "paper-fb", "--monte-carlo", "20000",
                                 "--json", "--plot", str(tmp_path / "c.png")])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert out["analytic"]["accuracy_percent"] == pytest.approx(0.375, abs=0.001)
    assert out["monte_carlo"]["accuracy_percent"] == pytest.approx(0.375, rel=0.05)
    assert (tmp_path / "c.png").stat().st_size > 1000


def test_cross_site_landmarks_file(tmp_path):
    f = tmp_path / "lm.yaml"
    f.write_text("f_px: 1189.0\nbaseline_m: 0.27\nsigma_p_px: 0.3333333333333333\nsigma_theta_px: 3.0\n"
                 "previous_site: [0, 0]\ncurrent_site: [10, 0]\n"
                 "landmarks: [[13, 1.5], [13, -1.5], [16, 1.5], [16, -1.5]]\n")
    r = CliRunner().invoke(cli, ["predict", "cross-site", "--landmarks", str(f), "--json"])
    assert json.loads(r.output)["analytic"]["accuracy_percent"] == pytest.approx(1.06, abs=0.005)
    f.write_text("landmarkz: []\n")
    with pytest.raises(VoError, match="landmarkz"):
        CliRunner().invoke(cli, ["predict", "cross-site", "--landmarks", str(f)], catch_exceptions=False)


@pytest.mark.parametrize("text, expected", [("5,10,20", [5, 10, 20]), ("1:3", [1, 2, 3]), ("2:10:4", [2, 6, 10])])
def test_parse_ranges(text, expected):
    assert parse_ranges(text).tolist() == expected


@pytest.mark.parametrize("text", ["", "a,b", "5:1", "0,1", "1:2:3:4"])
def test_parse_ranges_bad(text):
    with pytest.raises(VoError, match="ranges: "):
        parse_ranges(text)
