"""Field checks of the hand-read foreign calibration formats (EuRoC ``sensor.yaml``, Kalibr, KITTI).

Their keys are not our field names, so :mod:`rigs.calib_io` and :mod:`rigs.kalibr_io` read them by hand; each
value is still checked by the typed configuration's one validator (:func:`rigs.typed_config.check_value`), and
each failure is one line ``<source>: <field path>: <problem>``. Our own files are frozen dataclasses read by
:func:`rigs.typed_config.from_mapping`.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from rigs.errors import RigError
from rigs.typed_config import Spec, check_value


def field_error(source: str, path: str, problem: str, error=RigError):
    return error(f"{source}: {path}: {problem}")


def check_keys(d, required, optional, source: str, path: str, error=RigError) -> dict:
    """A mapping of a foreign calibration format (EuRoC, Kalibr; our own files are read by
    :func:`from_mapping`): every ``required`` key and nothing outside required+optional, with
    :func:`from_mapping`'s messages, prefixed by ``source``."""
    valid = list(required) + list(optional)
    if not isinstance(d, Mapping):
        raise field_error(source, path or "<top>", f"expected a mapping with keys {', '.join(valid)}, "
                                                   f"got {type(d).__name__}", error)
    prefix = f"{path}." if path else ""
    for k in d:
        if k not in valid:
            raise field_error(source, f"{prefix}{k}", f"unknown key; valid keys: {', '.join(valid)}", error)
    for k in required:
        if k not in d:
            raise field_error(source, f"{prefix}{k}", "missing field", error)
    return d


def field_number(value, source, path, positive=False, nonneg=False, error=RigError) -> float:
    """A finite real number (not bool, not a string); optionally > 0 or >= 0 (:func:`check_value`)."""
    spec = Spec(gt=0.0) if positive else Spec(ge=0.0) if nonneg else Spec()
    return check_value(value, float, spec, f"{source}: {path}", error)


def field_int(value, source, path, error=RigError) -> int:
    """A positive integer (an integral float such as 752.0 is accepted; :func:`check_value`)."""
    return check_value(value, int, Spec(ge=1), f"{source}: {path}", error)


def field_str(value, source, path, error=RigError) -> str:
    return check_value(value, str, Spec(), f"{source}: {path}", error)


def field_floats(value, source, path, lengths, error=RigError) -> tuple:
    """A list of finite numbers whose length is one of ``lengths``."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) not in lengths:
        raise field_error(source, path, f"expected a list of {' or '.join(map(str, lengths))} numbers, "
                                        f"got {value!r}", error)
    return check_value(value, tuple[float, ...], Spec(), f"{source}: {path}", error)
