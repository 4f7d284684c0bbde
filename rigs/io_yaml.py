"""Rig <-> YAML: strict reader/writer whose keys are exactly the dataclass field names.

File layout (``rigs/presets/*.yaml``)::

    name: stereo27
    cameras:                       # list; cameras[0] is the left/reference camera c0
    - {name, width, height, fx, fy, cx, cy, dist: [k1, k2, p1, p2, k3], T_b_c: 4x4 rows}
    imu: {name, rate_hz, accel_noise_density, gyro_noise_density,
          accel_random_walk, gyro_random_walk, T_b_i: 4x4 rows}
    camera_rate_hz: 20.0
    wheels: null                   # or {rate_hz, wheel_radius, track_width, ticks_per_rev, slip_std}
    mount: mast

Every malformed input raises :class:`rigs.errors.RigError` with one line
``<file>: <field path>: <problem>``, e.g. ``rigs/x.yaml: cameras[1].fx: must be a positive
finite number, got -3``. The small YAML helpers here (loader, atomic write, field checks) are
also used by :mod:`rigs.calib_io` and :mod:`rigs.overrides`.
"""
from __future__ import annotations

import dataclasses
import math
import os
import re
import tempfile
from pathlib import Path

import numpy as np
import yaml

from rigs.errors import RigError
from rigs.model import Camera, Imu, Rig, Wheels, as_matrix4

CAMERA_KEYS = tuple(f.name for f in dataclasses.fields(Camera))
IMU_KEYS = tuple(f.name for f in dataclasses.fields(Imu))
WHEELS_KEYS = tuple(f.name for f in dataclasses.fields(Wheels))
RIG_KEYS = tuple(f.name for f in dataclasses.fields(Rig))


# ----------------------------------------------------------------------------- YAML text level
class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``1e-4`` as a float (YAML 1.2; PyYAML's 1.1 rules need a dot)."""


_FLOAT_RE = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?
    |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X)
_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
for _ch in list("-+0123456789."):
    _Loader.yaml_implicit_resolvers.setdefault(_ch, [])
    _Loader.yaml_implicit_resolvers[_ch] = [
        (tag, rx) for tag, rx in _Loader.yaml_implicit_resolvers[_ch] if tag != "tag:yaml.org,2002:float"]
# Integers keep priority (resolvers are tried in order; int was registered before float).
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_RE, list("-+0123456789."))


def _strip_opencv_header(text: str) -> str:
    """OpenCV FileStorage files (EuRoC sensor.yaml) start with ``%YAML:1.0``, not valid YAML."""
    return re.sub(r"^%YAML[:\s]\s*1\.\d+[^\n]*\n", "", text.lstrip("\ufeff"), count=1)


def parse_yaml_text(text: str, source: str):
    """YAML text -> Python object; a syntax error becomes a one-line RigError naming ``source``."""
    try:
        return yaml.load(_strip_opencv_header(text), Loader=_Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise RigError(f"{source}: YAML syntax error{where}: {problem}") from None


def read_yaml_file(path) -> object:
    """Read and parse a YAML file; unreadable or malformed files raise RigError naming the path."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RigError(f"{path}: cannot read file: {getattr(exc, 'strerror', None) or exc}") from None
    return parse_yaml_text(text, str(path))


class _Dumper(yaml.SafeDumper):
    """Block style for mappings, flow style for lists of scalars (matrix rows, coefficients)."""


def _represent_list(dumper, data):
    flow = all(not isinstance(x, (list, tuple, dict)) for x in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", list(data), flow_style=flow)


_Dumper.add_representer(list, _represent_list)
_Dumper.add_representer(tuple, _represent_list)
# numpy scalars/arrays are written as the equivalent builtins.
_Dumper.add_multi_representer(np.floating, lambda d, x: d.represent_float(float(x)))
_Dumper.add_multi_representer(np.integer, lambda d, x: d.represent_int(int(x)))
_Dumper.add_multi_representer(np.bool_, lambda d, x: d.represent_bool(bool(x)))
_Dumper.add_representer(np.ndarray, lambda d, x: _represent_list(d, x.tolist()))


def dump_yaml(obj, header: str | None = None) -> str:
    """Object -> YAML text (floats written with ``repr`` precision), optional ``# `` header lines."""
    body = yaml.dump(obj, Dumper=_Dumper, sort_keys=False, default_flow_style=False, width=120)
    if not header:
        return body
    lines = "".join(f"# {ln}".rstrip() + "\n" for ln in header.splitlines())
    return lines + body


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` to ``path`` via a temp file in the same folder and ``os.replace``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ----------------------------------------------------------------------------- field checks
def field_error(source: str, path: str, problem: str) -> RigError:
    return RigError(f"{source}: {path}: {problem}")


def check_keys(d, required, optional, source: str, path: str) -> dict:
    """``d`` must be a mapping with every ``required`` key and nothing outside required+optional."""
    valid = list(required) + list(optional)
    if not isinstance(d, dict):
        raise field_error(source, path or "<top>", f"expected a mapping with keys {', '.join(valid)}, "
                                                   f"got {type(d).__name__}")
    prefix = f"{path}." if path else ""
    for k in d:
        if k not in valid:
            raise field_error(source, f"{prefix}{k}", f"unknown key; valid keys: {', '.join(valid)}")
    for k in required:
        if k not in d:
            raise field_error(source, f"{prefix}{k}", "missing field")
    return d


def field_number(value, source, path, positive=False, nonneg=False) -> float:
    """A finite real number (not bool, not a string); optionally > 0 or >= 0."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if positive and not (ok and value > 0):
        raise field_error(source, path, f"must be a positive finite number, got {value!r}")
    if nonneg and not (ok and value >= 0):
        raise field_error(source, path, f"must be a non-negative finite number, got {value!r}")
    if not ok:
        raise field_error(source, path, f"must be a finite number, got {value!r}")
    return float(value)


def field_int(value, source, path) -> int:
    """A positive integer (a float with an integral value such as 752.0 is accepted)."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
        raise field_error(source, path, f"must be a positive integer, got {value!r}")
    return value


def field_str(value, source, path) -> str:
    if not isinstance(value, str) or not value:
        raise field_error(source, path, f"must be a non-empty string, got {value!r}")
    return value


def field_floats(value, source, path, lengths) -> tuple:
    """A list of finite numbers whose length is one of ``lengths``."""
    if not isinstance(value, (list, tuple)) or len(value) not in lengths:
        raise field_error(source, path, f"expected a list of {' or '.join(map(str, lengths))} numbers, "
                                        f"got {value!r}")
    return tuple(field_number(v, source, f"{path}[{i}]") for i, v in enumerate(value))


def field_matrix4(value, source, path) -> tuple:
    """A 4x4 rigid transform given as 4 rows of 4 numbers -> nested tuple."""
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise field_error(source, path, f"expected 4 rows of 4 numbers, got {value!r}")
    rows = [field_floats(r, source, f"{path}[{i}]", (4,)) for i, r in enumerate(value)]
    try:
        return as_matrix4(rows, path)
    except RigError as exc:
        raise RigError(f"{source}: {exc}") from None


# ----------------------------------------------------------------------------- dict <-> Rig
def _matrix_list(T) -> list:
    return [[float(x) for x in row] for row in T]


def camera_to_dict(cam: Camera) -> dict:
    return {"name": cam.name, "width": cam.width, "height": cam.height, "fx": cam.fx, "fy": cam.fy,
            "cx": cam.cx, "cy": cam.cy, "dist": [float(x) for x in cam.dist], "T_b_c": _matrix_list(cam.T_b_c)}


def imu_to_dict(imu: Imu) -> dict:
    d = {k: getattr(imu, k) for k in IMU_KEYS}
    d["T_b_i"] = _matrix_list(imu.T_b_i)
    return d


def rig_to_dict(rig: Rig) -> dict:
    """Rig -> plain dict of builtins (keys = dataclass field names), ready for YAML."""
    wheels = None if rig.wheels is None else {k: getattr(rig.wheels, k) for k in WHEELS_KEYS}
    return {"name": rig.name, "cameras": [camera_to_dict(c) for c in rig.cameras],
            "imu": imu_to_dict(rig.imu), "camera_rate_hz": rig.camera_rate_hz,
            "wheels": wheels, "mount": rig.mount}


def camera_from_dict(d, source: str, path: str) -> Camera:
    check_keys(d, CAMERA_KEYS, (), source, path)
    return Camera(name=field_str(d["name"], source, f"{path}.name"),
                  width=field_int(d["width"], source, f"{path}.width"),
                  height=field_int(d["height"], source, f"{path}.height"),
                  fx=field_number(d["fx"], source, f"{path}.fx", positive=True),
                  fy=field_number(d["fy"], source, f"{path}.fy", positive=True),
                  cx=field_number(d["cx"], source, f"{path}.cx"),
                  cy=field_number(d["cy"], source, f"{path}.cy"),
                  dist=field_floats(d["dist"], source, f"{path}.dist", (4, 5)),
                  T_b_c=field_matrix4(d["T_b_c"], source, f"{path}.T_b_c"))


def imu_from_dict(d, source: str, path: str = "imu") -> Imu:
    check_keys(d, IMU_KEYS, (), source, path)
    kw = {k: field_number(d[k], source, f"{path}.{k}", nonneg=True)
          for k in ("accel_noise_density", "gyro_noise_density", "accel_random_walk", "gyro_random_walk")}
    return Imu(name=field_str(d["name"], source, f"{path}.name"),
               rate_hz=field_number(d["rate_hz"], source, f"{path}.rate_hz", positive=True),
               T_b_i=field_matrix4(d["T_b_i"], source, f"{path}.T_b_i"), **kw)


def wheels_from_dict(d, source: str, path: str = "wheels") -> Wheels:
    check_keys(d, WHEELS_KEYS, (), source, path)
    kw = {k: field_number(d[k], source, f"{path}.{k}", positive=True)
          for k in ("rate_hz", "wheel_radius", "track_width")}
    return Wheels(ticks_per_rev=field_int(d["ticks_per_rev"], source, f"{path}.ticks_per_rev"),
                  slip_std=field_number(d["slip_std"], source, f"{path}.slip_std", nonneg=True), **kw)


def rig_from_dict(d, source: str = "<dict>") -> Rig:
    """Strictly validated dict (as from :func:`rig_to_dict` or YAML) -> Rig."""
    check_keys(d, RIG_KEYS, (), source, "")
    cams = d["cameras"]
    if not isinstance(cams, list) or not cams:
        raise field_error(source, "cameras", f"expected a non-empty list of cameras, got {cams!r}")
    cameras = tuple(camera_from_dict(c, source, f"cameras[{i}]") for i, c in enumerate(cams))
    wheels = None if d["wheels"] is None else wheels_from_dict(d["wheels"], source)
    name = field_str(d["name"], source, "name")
    try:
        return Rig(name=name, cameras=cameras, imu=imu_from_dict(d["imu"], source),
                   camera_rate_hz=field_number(d["camera_rate_hz"], source, "camera_rate_hz", positive=True),
                   wheels=wheels, mount=field_str(d["mount"], source, "mount"))
    except RigError as exc:
        msg = str(exc)
        raise RigError(msg if msg.startswith(f"{source}: ") else f"{source}: {msg}") from None


def load_rig(path) -> Rig:
    """Read a rig YAML file (see module docstring); errors name the file and the field."""
    return rig_from_dict(read_yaml_file(path), source=str(path))


def save_rig(rig: Rig, path, header: str | None = None) -> None:
    """Write ``rig`` as YAML atomically (temp file + ``os.replace``), optional comment header."""
    write_text_atomic(path, dump_yaml(rig_to_dict(rig), header=header))


def load_dataclass(cls, path, error=RigError):
    """Build the frozen dataclass ``cls`` from a YAML file whose keys are its field names.

    Unreadable or malformed files, a non-mapping, unknown keys and invalid values raise ``error``
    with one line naming the file (and the field, where the dataclass's own validation names it).
    """
    import dataclasses
    try:
        data = read_yaml_file(path)
    except RigError as e:
        raise error(str(e)) from None
    data = {} if data is None else data
    if not isinstance(data, dict):
        raise error(f"{path}: expected a mapping of field names, got {type(data).__name__}")
    valid = sorted(f.name for f in dataclasses.fields(cls))
    unknown = sorted(set(data) - set(valid))
    if unknown:
        raise error(f"{path}: unknown field {unknown[0]!r}; valid: {', '.join(valid)}")
    try:
        return cls(**data)
    except (TypeError, ValueError, error) as e:
        raise error(f"{path}: {e}") from None
