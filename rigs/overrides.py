"""``key=value`` overrides on a Rig (``--set``); each returns a new validated Rig.

Keys are the field names of the rig dataclasses (:mod:`rigs.model`), resolved through
``dataclasses.fields`` and typed by their annotations (values parsed as YAML, ``1e-4`` a float):

- a plain :class:`~rigs.model.Rig` field: ``camera_rate_hz=F``, ``name=S``, ``mount=S``;
- ``imu.<field>`` (any :class:`~rigs.model.Imu` field), ``wheels.<field>`` (any
  :class:`~rigs.model.Wheels` field; a rig without wheels gets default ``Wheels()`` first);
- ``cam<k>.<field>`` (one camera) or ``cameras.<field>`` (all cameras): any
  :class:`~rigs.model.Camera` field, or one OpenCV coefficient ``k1, k2, p1, p2, k3`` of ``dist``;
- and three shorthands: ``baseline=B`` (move camera 1 along its current baseline direction so
  ``|t_c0_c1| = B``, c0 fixed), ``imu=NAME`` (a named model of :mod:`rigs.imu_models`, keeping the
  mounting ``T_b_i``), ``wheels=none`` / ``wheels=default``.

Values are checked by the rig classes themselves (typed configurations, :mod:`rigs.typed_config`: a field is
set with :func:`~rigs.typed_config.replace_path`), so a key and a rig file get the same checks. Errors are
one line: ``override 'baseline=-1': baseline: must be a positive finite number, got -1``.
These keys are the rig's grammar everywhere: a typed config with a rig field declares :data:`RIG_KEYS`
(``knob(..., keys=RIG_KEYS)``), so :func:`rigs.typed_config.replace_path` resolves ``rig.<key>`` here.
"""
from __future__ import annotations

import dataclasses
import re

import numpy as np

from rigs.errors import RigError
from rigs.imu_models import get_imu_model
from rigs.model import Camera, Imu, Rig, Wheels
from rigs.typed_config import KeyGrammar, apply_items, coerce, field_types, has_path, init_fields, replace_path

DIST_INDEX = {"k1": 0, "k2": 1, "p1": 2, "p2": 3, "k3": 4}     # OpenCV order of Camera.dist
EQUI_INDEX = {"k1": 0, "k2": 1, "k3": 2, "k4": 3}               # cv2.fisheye order (dist_model equidistant)
SHORTHANDS = ("baseline", "imu", "wheels")
_PLAIN = (str, int, float, bool)
_CAM_RE = re.compile(r"cam(\d+)$")


def _names(cls) -> tuple:
    return tuple(f.name for f in init_fields(cls))


def plain_rig_fields() -> tuple:
    """Rig fields with a scalar type (settable directly as ``name=value``)."""
    types = field_types(Rig)
    return tuple(n for n in _names(Rig) if types[n] in _PLAIN)


def camera_keys() -> tuple:
    return _names(Camera) + tuple(DIST_INDEX) + ("k4",)


def valid_keys(rig: Rig) -> list[str]:
    """All override keys valid for ``rig`` (camera keys depend on its number of cameras)."""
    cams = ["cameras"] + [f"cam{k}" for k in range(len(rig.cameras))]
    return (list(SHORTHANDS) + list(plain_rig_fields()) + [f"imu.<{'|'.join(_names(Imu))}>"]
            + [f"{c}.<{'|'.join(camera_keys())}>" for c in cams] + [f"wheels.<{'|'.join(_names(Wheels))}>"])


def is_key(rig: Rig, key: str) -> bool:
    """Whether ``key`` is an override key of ``rig``."""
    group, dot, name = key.partition(".")
    if not dot:
        return key in SHORTHANDS + plain_rig_fields()
    if group in ("imu", "wheels"):
        return "." not in name and has_path(Imu if group == "imu" else Wheels, name)
    return name in camera_keys() and _camera_indices(rig, group) is not None


def _camera_indices(rig: Rig, group: str):
    if group == "cameras":
        return range(len(rig.cameras))
    m = _CAM_RE.match(group)
    return [int(m.group(1))] if m and int(m.group(1)) < len(rig.cameras) else None


def with_baseline(rig: Rig, B: float) -> Rig:
    """Scale ``t_c0_c1`` to length ``B`` keeping its direction and ``R_c0_c1``; c0 stays put."""
    T_c0_c1 = rig.T_c0_c1.copy()
    T_c0_c1[:3, 3] *= B / np.linalg.norm(T_c0_c1[:3, 3])
    T_b_c1 = rig.cameras[0].T_b_c_array @ T_c0_c1
    cams = list(rig.cameras)
    cams[1] = dataclasses.replace(cams[1], T_b_c=T_b_c1)
    return dataclasses.replace(rig, cameras=tuple(cams))


def _set_camera(rig, indices, name, value, key):
    cams = list(rig.cameras)
    for k in indices:
        if name in DIST_INDEX or name == "k4":
            index = EQUI_INDEX if cams[k].is_fisheye else DIST_INDEX
            if name not in index:
                raise RigError(f"{key}: camera {cams[k].name!r} ({cams[k].dist_model}) has no coefficient {name}; "
                               f"valid: {', '.join(index)}")
            dist = list(cams[k].dist)
            dist[index[name]] = coerce(value, float, key, RigError)
            cams[k] = dataclasses.replace(cams[k], dist=tuple(dist))
        else:
            cams[k] = replace_path(cams[k], name, value, RigError, f"{key.partition('.')[0]}.")
    return dataclasses.replace(rig, cameras=tuple(cams))


def _set_shorthand(rig, key, value):
    if key == "baseline":
        if not rig.is_stereo:
            raise RigError(f"baseline: rig {rig.name!r} has one camera")
        B = coerce(value, float, key, RigError)
        if B <= 0:
            raise RigError(f"baseline: must be a positive finite number, got {value!r}")
        return with_baseline(rig, B)
    if key == "imu":
        model = get_imu_model(coerce(value, str, key, RigError))
        return dataclasses.replace(rig, imu=dataclasses.replace(model, T_b_i=rig.imu.T_b_i))
    if value in (None, "none", "None", "null"):
        return dataclasses.replace(rig, wheels=None)
    if value == "default":
        return dataclasses.replace(rig, wheels=Wheels())
    raise RigError(f"wheels: expected none or default, got {value!r}")


def set_key(rig: Rig, key: str, value) -> Rig:
    """``rig`` with override ``key`` set to the (already parsed) ``value``; errors name the key."""
    if not is_key(rig, key):
        raise RigError(f"{key}: unknown key; valid keys: {', '.join(valid_keys(rig))}")
    group, dot, name = key.partition(".")
    if not dot:
        return _set_shorthand(rig, key, value) if key in SHORTHANDS else replace_path(rig, key, value, RigError)
    if group == "imu":
        return replace_path(rig, key, value, RigError)
    if group == "wheels":
        return dataclasses.replace(rig, wheels=replace_path(rig.wheels or Wheels(), name, value, RigError, "wheels."))
    return _set_camera(rig, _camera_indices(rig, group), name, value, key)


def apply_overrides(rig: Rig, overrides=(), source: str = "override") -> Rig:
    """Apply ``key=value`` strings in order (:func:`rigs.typed_config.apply_items` with :func:`set_key`);
    returns a new validated Rig (``rig`` is unchanged); errors start with ``<source> '<item>': ``."""
    return apply_items(rig, overrides, RigError, source, setter=set_key)


RIG_KEYS = KeyGrammar(is_key, set_key, valid_keys)    # the rig's --set keys inside a typed config (``rig.<key>``)
