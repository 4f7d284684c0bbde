"""``key=value`` overrides on a Rig (CLI ``--rig-set``-style); each returns a new validated Rig.

Keys (values parsed as YAML, with ``1e-4`` read as a float):

- ``baseline=B``: move camera 1 along its current baseline direction so ``|t_c0_c1| = B`` (c0 fixed).
- ``camera_rate_hz=F``, ``name=S``, ``mount=S``.
- ``imu=NAME``: swap in a named model of :mod:`rigs.imu_models`, keeping the mounting ``T_b_i``.
- ``imu.<field>``: rate_hz, accel_noise_density, gyro_noise_density, accel_random_walk, gyro_random_walk, name.
- ``cam<k>.<field>`` (one camera) or ``cameras.<field>`` (all cameras): width, height, fx, fy, cx, cy,
  dist (list of 4 or 5), or one coefficient k1, k2, p1, p2, k3.
- ``wheels=none`` / ``wheels=default``; ``wheels.<field>``: rate_hz, wheel_radius, track_width,
  ticks_per_rev, slip_std (a rig without wheels gets default ``Wheels()`` first).

Errors are one line: ``override 'baseline=-1': baseline: must be a positive finite number, got -1``.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from rigs.errors import RigError
from rigs.imu_models import get_imu_model
from rigs.io_yaml import field_floats, field_int, field_number, field_str, parse_yaml_text
from rigs.model import Rig, Wheels

IMU_NUMBER_FIELDS = ("rate_hz", "accel_noise_density", "gyro_noise_density", "accel_random_walk",
                     "gyro_random_walk")
CAMERA_FIELDS = ("width", "height", "fx", "fy", "cx", "cy", "dist", "k1", "k2", "p1", "p2", "k3")
WHEELS_FIELDS = ("rate_hz", "wheel_radius", "track_width", "ticks_per_rev", "slip_std")
DIST_INDEX = {"k1": 0, "k2": 1, "p1": 2, "p2": 3, "k3": 4}


def valid_keys(rig: Rig) -> list[str]:
    """All override keys valid for ``rig`` (camera keys depend on its number of cameras)."""
    keys = ["baseline", "camera_rate_hz", "name", "mount", "imu", "wheels"]
    keys += [f"imu.{f}" for f in IMU_NUMBER_FIELDS + ("name",)]
    keys += [f"{c}.<{'|'.join(CAMERA_FIELDS)}>" for c in
             ["cameras"] + [f"cam{k}" for k in range(len(rig.cameras))]]
    keys += [f"wheels.<{'|'.join(WHEELS_FIELDS)}>"]
    return keys


def with_baseline(rig: Rig, B: float) -> Rig:
    """Scale ``t_c0_c1`` to length ``B`` keeping its direction and ``R_c0_c1``; c0 stays put."""
    T_c0_c1 = rig.T_c0_c1.copy()
    T_c0_c1[:3, 3] *= B / np.linalg.norm(T_c0_c1[:3, 3])
    T_b_c1 = rig.cameras[0].T_b_c_array @ T_c0_c1
    cams = list(rig.cameras)
    cams[1] = dataclasses.replace(cams[1], T_b_c=T_b_c1)
    return dataclasses.replace(rig, cameras=tuple(cams))


def _camera_value(field, value, src, key, cam):
    if field in ("width", "height"):
        return field_int(value, src, key)
    if field in ("fx", "fy"):
        return field_number(value, src, key, positive=True)
    if field in ("cx", "cy"):
        return field_number(value, src, key)
    if field == "dist":
        return field_floats(value, src, key, (4, 5))
    dist = list(cam.dist)
    dist[DIST_INDEX[field]] = field_number(value, src, key)
    return tuple(dist)


def _set_camera(rig, indices, field, value, src, key):
    cams = list(rig.cameras)
    for k in indices:
        target = "dist" if field in DIST_INDEX else field
        cams[k] = dataclasses.replace(cams[k], **{target: _camera_value(field, value, src, key, cams[k])})
    return dataclasses.replace(rig, cameras=tuple(cams))


def _set_imu(rig, field, value, src, key):
    v = field_str(value, src, key) if field == "name" else \
        field_number(value, src, key, positive=(field == "rate_hz"), nonneg=(field != "rate_hz"))
    return dataclasses.replace(rig, imu=dataclasses.replace(rig.imu, **{field: v}))


def _set_wheels(rig, field, value, src, key):
    v = field_int(value, src, key) if field == "ticks_per_rev" else \
        field_number(value, src, key, positive=(field != "slip_std"), nonneg=(field == "slip_std"))
    return dataclasses.replace(rig, wheels=dataclasses.replace(rig.wheels or Wheels(), **{field: v}))


def _unknown(rig, src, key):
    return RigError(f"{src}: {key}: unknown key; valid keys: {', '.join(valid_keys(rig))}")


def _apply_top(rig, key, value, src):
    if key == "baseline":
        if not rig.is_stereo:
            raise RigError(f"{src}: baseline: rig {rig.name!r} has one camera")
        return with_baseline(rig, field_number(value, src, key, positive=True))
    if key == "camera_rate_hz":
        return dataclasses.replace(rig, camera_rate_hz=field_number(value, src, key, positive=True))
    if key in ("name", "mount"):
        return dataclasses.replace(rig, **{key: field_str(value, src, key)})
    if key == "imu":
        model = get_imu_model(field_str(value, src, key))
        return dataclasses.replace(rig, imu=dataclasses.replace(model, T_b_i=rig.imu.T_b_i))
    if key == "wheels" and value in (None, "none", "None", "null"):
        return dataclasses.replace(rig, wheels=None)
    if key == "wheels" and value == "default":
        return dataclasses.replace(rig, wheels=Wheels())
    if key == "wheels":
        raise RigError(f"{src}: wheels: expected none or default, got {value!r}")
    raise _unknown(rig, src, key)


def _apply_dotted(rig, key, value, src):
    group, field = key.split(".", 1)
    if group == "imu" and field in IMU_NUMBER_FIELDS + ("name",):
        return _set_imu(rig, field, value, src, key)
    if group == "wheels" and field in WHEELS_FIELDS:
        return _set_wheels(rig, field, value, src, key)
    if field in CAMERA_FIELDS and group == "cameras":
        return _set_camera(rig, range(len(rig.cameras)), field, value, src, key)
    if field in CAMERA_FIELDS and group.startswith("cam") and group[3:].isdigit() \
            and int(group[3:]) < len(rig.cameras):
        return _set_camera(rig, [int(group[3:])], field, value, src, key)
    raise _unknown(rig, src, key)


def apply_override(rig: Rig, item: str) -> Rig:
    """One ``key=value`` string -> new Rig."""
    src = f"override {item!r}"
    if not isinstance(item, str) or "=" not in item:
        raise RigError(f"{src}: expected key=value; valid keys: {', '.join(valid_keys(rig))}")
    key, text = (s.strip() for s in item.split("=", 1))
    value = parse_yaml_text(text, src)
    try:
        return (_apply_dotted if "." in key else _apply_top)(rig, key, value, src)
    except RigError as exc:
        msg = str(exc)
        raise RigError(msg if msg.startswith(src) else f"{src}: {msg}") from None


def apply_overrides(rig: Rig, overrides=()) -> Rig:
    """Apply ``key=value`` strings in order; returns a new validated Rig (``rig`` is unchanged)."""
    if isinstance(overrides, str):
        overrides = [overrides]
    for item in overrides:
        rig = apply_override(rig, item)
    return rig
