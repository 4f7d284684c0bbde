"""Rig YAML round trip and strict, one-line error messages."""
import dataclasses
import os

import pytest
import yaml

from rigs import RigError, Wheels
from rigs.config_io import parse_yaml_text
from rigs.rig_yaml import load_rig, rig_from_dict, rig_to_dict, save_rig
from rigs.presets import get_rig, rig_names


def _one_line_error(fn, *args):
    with pytest.raises(RigError) as e:
        fn(*args)
    msg = str(e.value)
    assert "\n" not in msg, msg
    return msg


@pytest.mark.parametrize("name", rig_names())
def test_save_load_round_trip_is_equal(tmp_path, name):
    rig = dataclasses.replace(get_rig(name), wheels=Wheels(slip_std=0.02))
    path = tmp_path / "sub" / "rig.yaml"
    save_rig(rig, path, header="test header\nsecond line")
    assert load_rig(path) == rig                     # exact: floats written with repr precision
    assert [p.name for p in path.parent.iterdir()] == ["rig.yaml"]   # no temp file left behind
    assert path.read_text().startswith("# test header\n# second line\n")


def test_dict_keys_are_field_names():
    d = rig_to_dict(get_rig("stereo27"))
    assert list(d) == ["name", "cameras", "imu", "camera_rate_hz", "wheels", "mount"]
    assert set(d["cameras"][0]) == {"name", "width", "height", "fx", "fy", "cx", "cy", "dist", "T_b_c"}
    assert d["wheels"] is None and len(d["cameras"][1]["T_b_c"]) == 4


def test_exponent_without_dot_reads_as_float():
    # PyYAML's YAML 1.1 rules would give the string '1e-4'.
    assert parse_yaml_text("a: 1e-4\nb: 3\nc: -2.5E+3", "x") == {"a": 1e-4, "b": 3, "c": -2500.0}


def test_malformed_yaml_names_file(tmp_path):
    path = tmp_path / "x.yaml"
    path.write_text("name: a\ncameras: [\n  {name: cam0\n")
    msg = _one_line_error(load_rig, path)
    assert msg.startswith(f"{path}: YAML syntax error")


def _write(tmp_path, d):
    path = tmp_path / "x.yaml"
    path.write_text(yaml.safe_dump(d))
    return path


def test_missing_field(tmp_path):
    d = rig_to_dict(get_rig("stereo27"))
    del d["cameras"][1]["fx"]
    path = _write(tmp_path, d)
    assert _one_line_error(load_rig, path) == f"{path}: cameras[1].fx: missing field"


def test_negative_focal_length(tmp_path):
    d = rig_to_dict(get_rig("stereo27"))
    d["cameras"][1]["fx"] = -3
    path = _write(tmp_path, d)
    assert _one_line_error(load_rig, path) == f"{path}: cameras[1].fx: must be a positive number, got -3.0"


def test_unknown_key_lists_valid_keys(tmp_path):
    d = rig_to_dict(get_rig("stereo27"))
    d["imu"]["gyro_noise"] = 1.0
    msg = _one_line_error(load_rig, _write(tmp_path, d))
    assert "imu.gyro_noise: unknown key; valid keys: name, rate_hz" in msg and "gyro_noise_density" in msg


@pytest.mark.parametrize("field, value, expect", [
    ("width", "752", "cameras[0].width: must be an integer, got '752'"),
    ("fx", True, "cameras[0].fx: must be a finite number, got True"),
    ("dist", [0.1, 0.2], "cameras[0]: camera 'cam0'.dist: expected 4 or 5 finite OpenCV coefficients"),
    ("T_b_c", [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "cameras[0].T_b_c: not a rigid transform"),
    ("T_b_c", [[1, 0, 0], [0, 1, 0]], "cameras[0].T_b_c: expected a list of 4 values"),
])
def test_wrong_types(field, value, expect):
    d = rig_to_dict(get_rig("stereo27"))
    d["cameras"][0][field] = value
    msg = _one_line_error(rig_from_dict, d, "f.yaml")
    assert msg.startswith(f"f.yaml: {expect}"), msg


def test_duplicate_camera_names_name_the_file():
    d = rig_to_dict(get_rig("stereo27"))
    d["cameras"][1]["name"] = "cam0"
    assert _one_line_error(rig_from_dict, d, "f.yaml").startswith("f.yaml: rig 'stereo27'.cameras: duplicate")


def test_missing_file():
    assert "nope.yaml: cannot read file" in _one_line_error(load_rig, os.path.join("no", "nope.yaml"))
