"""Rig <-> YAML: strict reader/writer whose keys are exactly the dataclass field names.

File layout (``rigs/presets/*.yaml``)::

    name: stereo27
    cameras:                       # list; cameras[0] is the left/reference camera c0
    - {name, width, height, fx, fy, cx, cy, dist: [k1, k2, p1, p2, k3], T_b_c: 4x4 rows}
      # a fisheye camera adds ``dist_model: equidistant`` and has dist: [k1, k2, k3, k4]
      # (optional key; absent = radtan)
    imu: {name, rate_hz, accel_noise_density, gyro_noise_density,
          accel_random_walk, gyro_random_walk, T_b_i: 4x4 rows}
    camera_rate_hz: 20.0
    wheels: null                   # or {rate_hz, wheel_radius, track_width, ticks_per_rev, slip_std}
    mount: mast

Every malformed input raises :class:`rigs.errors.RigError` with one line
``<file>: <field path>: <problem>``, e.g. ``rigs/x.yaml: cameras[1].fx: must be a positive
finite number, got -3``. The generic YAML reader/writer and field checks it uses live in
:mod:`rigs.config_io`.
"""
from __future__ import annotations

import dataclasses

from rigs.atomic_io import atomic_write_text
from rigs.config_io import (check_keys, dump_yaml, field_error, field_floats, field_int, field_number, field_str,
                            read_yaml_file)
from rigs.errors import RigError
from rigs.model import DIST_MODELS, Camera, Imu, Rig, Wheels, as_matrix4

CAMERA_KEYS = tuple(f.name for f in dataclasses.fields(Camera))
IMU_KEYS = tuple(f.name for f in dataclasses.fields(Imu))
WHEELS_KEYS = tuple(f.name for f in dataclasses.fields(Wheels))
RIG_KEYS = tuple(f.name for f in dataclasses.fields(Rig))


# ----------------------------------------------------------------------------- rig fields
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
    """Camera -> dict; ``dist_model`` only for a non-default (equidistant) lens model."""
    d = {"name": cam.name, "width": cam.width, "height": cam.height, "fx": cam.fx, "fy": cam.fy,
         "cx": cam.cx, "cy": cam.cy, "dist": [float(x) for x in cam.dist], "T_b_c": _matrix_list(cam.T_b_c)}
    if cam.dist_model != "radtan":
        d["dist_model"] = cam.dist_model
    return d


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
    check_keys(d, tuple(k for k in CAMERA_KEYS if k != "dist_model"), ("dist_model",), source, path)
    model = field_str(d.get("dist_model", "radtan"), source, f"{path}.dist_model")
    if model not in DIST_MODELS:
        raise field_error(source, f"{path}.dist_model", f"expected one of {', '.join(DIST_MODELS)}, got {model!r}")
    n_dist = (4,) if model == "equidistant" else (4, 5)
    return Camera(dist_model=model, name=field_str(d["name"], source, f"{path}.name"),
                  width=field_int(d["width"], source, f"{path}.width"),
                  height=field_int(d["height"], source, f"{path}.height"),
                  fx=field_number(d["fx"], source, f"{path}.fx", positive=True),
                  fy=field_number(d["fy"], source, f"{path}.fy", positive=True),
                  cx=field_number(d["cx"], source, f"{path}.cx"),
                  cy=field_number(d["cy"], source, f"{path}.cy"),
                  dist=field_floats(d["dist"], source, f"{path}.dist", n_dist),
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
    wheels = None if d["wheels"] is None else wheels_from_dict(d["wheels"], source)
    name = field_str(d["name"], source, "name")
    try:
        cameras = tuple(camera_from_dict(c, source, f"cameras[{i}]") for i, c in enumerate(cams))
        return Rig(name=name, cameras=cameras, imu=imu_from_dict(d["imu"], source),
                   camera_rate_hz=field_number(d["camera_rate_hz"], source, "camera_rate_hz", positive=True),
                   wheels=wheels, mount=field_str(d["mount"], source, "mount")).check_stereo()
    except RigError as exc:
        msg = str(exc)
        raise RigError(msg if msg.startswith(f"{source}: ") else f"{source}: {msg}") from None


def load_rig(path) -> Rig:
    """Read a rig YAML file (see module docstring); errors name the file and the field."""
    return rig_from_dict(read_yaml_file(path), source=str(path))


def save_rig(rig: Rig, path, header: str | None = None) -> None:
    """Write ``rig`` as YAML atomically (temp file + ``os.replace``), optional comment header."""
    atomic_write_text(path, dump_yaml(rig_to_dict(rig), header=header))
