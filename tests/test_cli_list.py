"""`vo-testbed list` details (also as JSON) and `vo-testbed --version`."""
from __future__ import annotations

import json
import math

from click.testing import CliRunner

from sim.app.cli import cli


def test_version():
    from importlib.metadata import version
    from sim.version import __version__ as dataset_version
    r = CliRunner().invoke(cli, ["--version"])
    assert r.exit_code == 0
    assert r.output.strip() == f"vo-testbed {version('vo-testbed')} (dataset version {dataset_version})"


def test_list_json_details_match_the_definitions():
    r = CliRunner().invoke(cli, ["list", "--json"])
    assert r.exit_code == 0, r.output
    cat = json.loads(r.output)
    # campus: offset loop 2 (18.5 + 12.5) + 2 pi 4.5 m (scenes/campus.py), 7 GCPs
    assert math.isclose(cat["scenes"]["campus"]["route_length_m"], 62 + 9 * math.pi, abs_tol=0.01)
    assert len(cat["scenes"]["campus"]["gcps"]) == 7 and cat["scenes"]["campus"]["closed"]
    assert "scene.texture_richness" in cat["scene_knobs"]
    cart = cat["rigs"]["cart27"]
    assert cart["resolution"] == [720, 480] and cart["baseline_m"] == 0.2857 and cart["camera_rate_hz"] == 10
    # smoke: 3 s of stereo27 at 20 Hz, both ends included; campus-short: 10 s at 10 Hz
    assert cat["scenarios"]["smoke"] == {**cat["scenarios"]["smoke"], "scene": "indoor", "rig": "stereo27",
                                         "duration_s": 3.0, "frames": 61}
    assert cat["scenarios"]["campus-short"]["frames"] == 101
    assert set(cat["estimators"]) >= {"rop", "klt-pnp", "orb-pnp"}
    assert all(isinstance(v, str) and v and "\n" not in v for v in cat["estimators"].values())
    assert set(cat["plugins"]) == {"scene", "rig", "estimator"}


def test_list_text_has_one_line_per_item():
    r = CliRunner().invoke(cli, ["list"])
    assert r.exit_code == 0
    assert "cart27           720x480, baseline 0.2857 m, camera 10 Hz" in r.output
    assert "smoke            scene indoor, rig stereo27, 3 s, 61 frames" in r.output
    assert "--scene package.module:SceneClass" in r.output and "--rig path/to/rig.yaml" in r.output
    names = CliRunner().invoke(cli, ["list", "--names"])
    assert "scenarios: campus, campus-realistic, campus-short" in names.output
