"""Generic YAML I/O and one-line field checks, shared by every config and calibration reader.

* :func:`parse_yaml_text` / :func:`read_yaml_file`: YAML 1.2-style numbers (``1e-4`` is a float),
  OpenCV ``%YAML:1.0`` headers tolerated; a syntax error or an unreadable file is one line naming
  the source.
* :func:`dump_yaml`: block mappings, flow lists of scalars, floats at ``repr`` precision, numpy
  values as builtins.

Checking the values read is the typed configuration's job (:mod:`rigs.typed_config`: our files are read as
frozen dataclasses; the foreign calibration formats through :mod:`rigs.calib_fields`).

Every error is ``error`` (default :class:`rigs.errors.RigError`), so each package raises its own
subclass of :class:`rigs.errors.TestbedError`.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import yaml

from rigs.errors import RigError


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


def parse_yaml_text(text: str, source: str, error=RigError):
    """YAML text -> Python object; a syntax error becomes a one-line ``error`` naming ``source``."""
    try:
        return yaml.load(_strip_opencv_header(text), Loader=_Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise error(f"{source}: YAML syntax error{where}: {problem}") from None


def read_yaml_file(path, error=RigError) -> object:
    """Read and parse a YAML file; unreadable or malformed files raise ``error`` naming the path."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read file: {getattr(exc, 'strerror', None) or exc}") from None
    return parse_yaml_text(text, str(path), error)


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
