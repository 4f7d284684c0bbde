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
number, got -3.0``. The file is read as the typed configuration it is (:func:`rigs.typed_config.from_mapping`
on :class:`rigs.model.Rig`): the keys are the field names, checked by the fields' annotations and ranges;
every field is required but ``dist_model`` (radtan when absent).
"""
from __future__ import annotations

import dataclasses

from rigs.atomic_io import atomic_write_text
from rigs.config_io import dump_yaml, read_yaml_file
from rigs.errors import RigError
from rigs.model import Camera, Imu, Rig, Wheels
from rigs.typed_config import from_mapping

IMU_KEYS = tuple(f.name for f in dataclasses.fields(Imu))
WHEELS_KEYS = tuple(f.name for f in dataclasses.fields(Wheels))


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


def rig_from_dict(d, source: str = "<dict>") -> Rig:
    """Strictly validated dict (as from :func:`rig_to_dict` or YAML) -> Rig; errors ``<source>: <field>: ...``."""
    try:
        return from_mapping(Rig, d, RigError).check_stereo()
    except RigError as exc:
        msg = str(exc)
        raise RigError(msg if msg.startswith(f"{source}: ") else f"{source}: {msg}") from None


def load_rig(path) -> Rig:
    """Read a rig YAML file (see module docstring); errors name the file and the field."""
    return rig_from_dict(read_yaml_file(path), source=str(path))


def save_rig(rig: Rig, path, header: str | None = None) -> None:
    """Write ``rig`` as YAML atomically (temp file + ``os.replace``), optional comment header."""
    atomic_write_text(path, dump_yaml(rig_to_dict(rig), header=header))
