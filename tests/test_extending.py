"""docs/extending.md works as printed: its scene, rig YAML and estimator files and its commands are run.

The files are cut out of the page (each block follows a ``<!-- file: NAME -->`` line) and the
``<!-- commands -->`` block is run line by line through the console entry point, in a fresh folder.
The stand-still estimator gives a check against exact truth: its drift is the distance between the
true first and last camera positions.
"""
from __future__ import annotations

import json
import re
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest

from sim.app.cli import main

DOC = Path(__file__).resolve().parents[1] / "docs" / "extending.md"


def doc_files() -> dict:
    return dict(re.findall(r"<!-- file: (\S+) -->\n```\w+\n(.*?)```", DOC.read_text(), re.S))


def doc_commands() -> list:
    block = re.search(r"<!-- commands -->\n```sh\n(.*?)```", DOC.read_text(), re.S).group(1)
    return [shlex.split(line)[1:] for line in block.strip().splitlines()]     # drop "PYTHONPATH=."


def vo_testbed(args):
    try:
        main(args)
    except SystemExit as e:
        assert e.code == 0, f"{args}: exit {e.code}"


@pytest.fixture(scope="module")
def worked_example(tmp_path_factory):
    folder = tmp_path_factory.mktemp("extending")
    for name, body in doc_files().items():
        (folder / name).write_text(body)
    cwd, path = Path.cwd(), list(sys.path)
    try:
        import os
        os.chdir(folder)
        sys.path.insert(0, str(folder))                  # what PYTHONPATH=. does
        for cmd in doc_commands():
            assert cmd[0] == "vo-testbed"
            vo_testbed(cmd[1:] + (["--no-progress"] if cmd[1] == "run" else []))
    finally:
        os.chdir(cwd)
        sys.path[:] = path
    return folder


def test_doc_has_the_three_plugins():
    assert set(doc_files()) == {"my_scene.py", "my_rig.yaml", "my_vo.py"}


def test_plugin_scene_and_rig_yaml_make_the_dataset(worked_example):
    from vo.dataset import open_dataset
    ds = open_dataset(worked_example / "out" / "street")
    assert ds.rig.name == "small-stereo" and ds.rig.cameras[0].width == 320
    assert abs(ds.rig.baseline - 0.2) < 1e-12
    assert len(ds) == 31                                  # 3 s at the rig's 10 Hz, both ends included
    assert ds.metadata["config"]["scene"]["name"] == "my_scene:StreetScene"
    gt = ds.groundtruth_cam0()
    assert np.all(np.diff(gt.positions[:, 0]) >= 0)       # drives along +x, the street's route


def test_plugin_estimator_drift_is_the_distance_travelled(worked_example):
    from vo.dataset import open_dataset
    metrics = json.loads((worked_example / "out" / "stand-still" / "metrics.json").read_text())["metrics"]
    gt = open_dataset(worked_example / "out" / "street").groundtruth_cam0()
    travelled = float(np.linalg.norm(gt.positions[-1] - gt.positions[0]))
    assert metrics["drift"]["end_diff_m"] == pytest.approx(travelled, abs=1e-9)
    assert metrics["coverage"]["fraction"] == 1.0


def test_builtin_estimator_runs_on_the_plugin_scene(worked_example):
    metrics = json.loads((worked_example / "out" / "klt" / "metrics.json").read_text())["metrics"]
    assert metrics["drift"]["drift_ratio_pct"] < 5.0      # the crates give KLT enough texture to track


def test_list_documents_the_plugins():
    from sim.app.catalogue import catalogue
    plugins = catalogue(details=False)["plugins"]
    assert "package.module:SceneClass" in plugins["scene"] and ".yaml" in plugins["rig"]
