"""Typed configuration: frozen dataclasses whose YAML keys and ``--set`` keys are their field names.

A config class states each field's type in its annotation (``bool``, ``int``, ``float``, ``str``,
``Literal[...]``, ``Optional[X]``, ``tuple[X, ...]`` or a nested config dataclass) and, where a
range applies, declares it with :func:`knob` (``ge``/``gt``/``le``/``lt``, ``odd``, a ``parse``
hook for values given another way, such as a preset name). Its ``__post_init__`` calls :func:`check_fields`, which coerces
every value by its annotation, range-checks it and raises one line naming the field:

    @dataclass(frozen=True)
    class RenderConfig:
        supersample: int = knob(1, ge=1, le=7, odd=True)

        def __post_init__(self):
            check_fields(self, SimError, "render.")

So adding a knob is adding one field; a YAML file (:func:`from_mapping`, :func:`load_dataclass`)
and a dotted ``--set a.b=v`` (:func:`replace_path`) get the same checks. Type rules: a bool must
be a bool; an int is an integer (an integral float such as ``752.0`` is accepted), never a bool;
a float is a finite real number (NaN and inf are rejected), never a bool or a string; ``None``
(or ``none``) only where the annotation is ``Optional``.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import MISSING, dataclass

import numpy as np

from rigs.config_io import parse_yaml_text, read_yaml_file
from rigs.errors import TestbedError


@dataclass(frozen=True)
class Spec:
    """Per-field checks beyond the annotated type: bounds, oddness, and a ``parse(value)`` hook that
    turns any value not already of the field's type (a preset name, a mapping) into it. ``keys``: the
    field's own sub-key grammar (:class:`KeyGrammar`) for a value that is not a config dataclass, such as
    the rig (:data:`rigs.overrides.RIG_KEYS`); :func:`replace_path` hands it the rest of a dotted key.
    ``required``: :func:`from_mapping` refuses a mapping without it (a rig file must state every extrinsic).
    ``check``: a last test of the coerced value that returns the problem (a 4x4 that is not rigid), or None.
    ``bare``: the ``keys`` of the field may be given without its name (``baseline=0.1`` for ``rig.baseline=0.1``)."""

    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    odd: bool = False
    parse: typing.Callable | None = None
    keys: "KeyGrammar | None" = None
    required: bool = False          # a mapping (file) must give it, though code may leave it at its default
    check: typing.Callable | None = None   # check(value) -> why the (coerced) value is wrong, or None
    bare: bool = False              # its KeyGrammar's keys may leave out the field's name (``baseline=``)

    def problem(self, v) -> str | None:
        """Why ``v`` (already of the field's type) is out of range, or None."""
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            return None
        lo_ok = (self.ge is None or v >= self.ge) and (self.gt is None or v > self.gt)
        hi_ok = (self.le is None or v <= self.le) and (self.lt is None or v < self.lt)
        if not (lo_ok and hi_ok):
            return f"must be {self.describe()}, got {v!r}"
        if self.odd and v % 2 == 0:
            return f"must be odd, got {v!r}"
        return None

    def describe(self) -> str:
        if self.le is None and self.lt is None and (self.ge, self.gt) in ((0, None), (None, 0)):
            return "a non-negative number" if self.ge == 0 else "a positive number"
        lo = f"[{_num(self.ge)}" if self.ge is not None else f"({_num(self.gt)}" if self.gt is not None else None
        hi = f"{_num(self.le)}]" if self.le is not None else f"{_num(self.lt)})" if self.lt is not None else None
        if lo and hi:
            return f"in {lo}, {hi}"
        if lo:
            return (">= " if lo[0] == "[" else "> ") + lo[1:]
        return ("<= " if hi[-1] == "]" else "< ") + hi[:-1]


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


@dataclass(frozen=True)
class KeyGrammar:
    """The dotted sub-keys of a field value with its own key language: ``is_key(value, key)``,
    ``set_key(value, key, parsed) -> new value`` (errors name the key) and ``valid_keys(value) -> list``."""

    is_key: typing.Callable
    set_key: typing.Callable
    valid_keys: typing.Callable


def knob(default=MISSING, *, default_factory=MISSING, ge=None, gt=None, le=None, lt=None, odd=False, parse=None,
         keys: KeyGrammar | None = None, required: bool = False, check=None, bare: bool = False, doc: str = ""):
    """A dataclass field with a :class:`Spec` (and a one-line ``doc``) in its metadata."""
    meta = {"spec": Spec(ge, gt, le, lt, odd, parse, keys, required, check, bare), "doc": doc}
    return dataclasses.field(default=default, default_factory=default_factory, metadata=meta)


@functools.lru_cache(maxsize=None)
def field_types(cls) -> dict:
    """Resolved annotations of dataclass ``cls`` (string annotations evaluated once)."""
    return typing.get_type_hints(cls)


def init_fields(cls) -> list:
    return [f for f in dataclasses.fields(cls) if f.init]


# ----------------------------------------------------------------------------- coercion by annotation
def coerce(value, tp, path: str, error):
    """``value`` as annotated type ``tp``; otherwise ``error('<path>: must be ..., got <value>')``."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is typing.Union or origin is types.UnionType:      # Optional[X] and X | None
        inner = [a for a in args if a is not type(None)]
        if type(None) in args and (value is None or (isinstance(value, str) and value.lower() == "none")):
            return None
        return coerce(value, inner[0] if len(inner) == 1 else typing.Any, path, error)
    if origin is typing.Literal:
        if value in args and not isinstance(value, bool):
            return value
        raise error(f"{path}: unknown {value!r}; valid: {', '.join(map(str, args))}")
    if tp is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise error(f"{path}: must be true or false, got {value!r}")
    if tp is int:
        return _as_int(value, path, error)
    if tp is float:
        ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
        if ok and math.isfinite(value):
            return float(value)
        raise error(f"{path}: must be a finite number, got {value!r}")
    if tp is str:
        if isinstance(value, str) and value:
            return value
        raise error(f"{path}: must be a non-empty string, got {value!r}")
    if tp is tuple or origin is tuple:
        return _as_tuple(value, args, path, error)
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        if isinstance(value, tp):
            return value
        if isinstance(value, Mapping):
            return from_mapping(tp, value, error, path)
        raise error(f"{path}: expected a mapping with keys {', '.join(f.name for f in init_fields(tp))}, "
                    f"got {value!r}")
    return value


def _as_int(value, path, error) -> int:
    if isinstance(value, (float, np.floating)) and math.isfinite(value) and float(value).is_integer():
        value = int(value)
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        return int(value)
    raise error(f"{path}: must be an integer, got {value!r}")


def _as_tuple(value, args, path, error) -> tuple:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)):
        raise error(f"{path}: expected a list, got {value!r}")
    if not args:
        return tuple(value)
    if len(args) == 2 and args[1] is Ellipsis:
        return tuple(coerce(v, args[0], f"{path}[{i}]", error) for i, v in enumerate(value))
    if len(value) != len(args):
        raise error(f"{path}: expected a list of {len(args)} values, got {value!r}")
    return tuple(coerce(v, t, f"{path}[{i}]", error) for i, (v, t) in enumerate(zip(value, args)))


def check_fields(obj, error, prefix: str = "") -> None:
    """Coerce every field of the frozen dataclass ``obj`` to its annotated type and apply its
    :class:`Spec`; call from ``__post_init__``. ``prefix`` (e.g. ``"scene."``) starts each field path."""
    types = field_types(type(obj))
    for f in init_fields(type(obj)):
        value = check_value(getattr(obj, f.name), types[f.name], f.metadata.get("spec") or Spec(), prefix + f.name,
                            error)
        object.__setattr__(obj, f.name, value)


def check_value(value, tp, spec: Spec, path: str, error):
    """``value`` of a field annotated ``tp`` with :class:`Spec` ``spec``: parsed (``spec.parse``), coerced by
    the annotation and range-checked; every problem one ``error`` line ``<path>: <problem>``. The one
    validator of configuration values: fields (:func:`check_fields`), mappings (:func:`from_mapping`),
    ``--set`` items (:func:`replace_path`) and the hand-read calibration formats (:mod:`rigs.calib_fields`)."""
    if spec.parse is not None and not _is_instance(value, tp):
        value = spec.parse(value)
    value = coerce(value, tp, path, error)
    problem = spec.problem(value) or (spec.check(value) if spec.check is not None else None)
    if problem:
        raise error(f"{path}: {problem}")
    return value


def _field_spec(cls, name: str) -> Spec:
    return next(f for f in init_fields(cls) if f.name == name).metadata.get("spec") or Spec()


def _is_instance(value, tp) -> bool:
    return isinstance(tp, type) and isinstance(value, tp)


# ----------------------------------------------------------------------------- mappings and files
def from_mapping(cls, data, error, path: str = ""):
    """Build ``cls`` from a mapping whose keys are its field names (missing keys take the defaults, but for
    fields declared ``required``). Unknown keys, missing and bad values raise ``error`` in one line naming the
    field path (``cameras[1].fx``: nested configs and lists of them included)."""
    data = {} if data is None else data
    if not isinstance(data, Mapping):
        raise error(f"{path or '<top>'}: expected a mapping of field names, got {type(data).__name__}")
    where = (lambda key: f"{path}.{key}") if path else str
    fields = init_fields(cls)
    names = [f.name for f in fields]
    for key in data:
        if key not in names:
            raise error(f"{where(key)}: unknown key; valid keys: {', '.join(names)}")
    types = field_types(cls)
    values = {}
    for f in fields:
        spec = f.metadata.get("spec") or Spec()
        if f.name in data:
            values[f.name] = check_value(data[f.name], types[f.name], spec, where(f.name), error)
        elif spec.required or (f.default is MISSING and f.default_factory is MISSING):
            raise error(f"{where(f.name)}: missing field")
    try:
        return cls(**values)
    except TestbedError as exc:       # a check across fields (__post_init__): say where the mapping sits
        if not path or str(exc).startswith(f"{path}"):
            raise
        raise type(exc)(f"{path}: {exc}") from None


def to_mapping(obj):
    """Dataclass (nested) -> plain dict of builtins (tuples as lists), keys = field names."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_mapping(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_mapping(v) for v in obj]
    if isinstance(obj, dict):
        return {k: to_mapping(v) for k, v in obj.items()}
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def load_dataclass(cls, path, error):
    """Build the frozen dataclass ``cls`` from a YAML file whose keys are its field names; every
    problem is one ``error`` line starting with the file path."""
    data = read_yaml_file(path, error)
    try:
        return from_mapping(cls, data, error)
    except TestbedError as exc:
        raise type(exc)(f"{path}: {exc}") from None


# ----------------------------------------------------------------------------- dotted keys
def parse_value(text: str, source: str, error):
    """The value part of ``key=value``, parsed as YAML (``1e-4`` a float, ``true`` a bool)."""
    return parse_yaml_text(text, source, error)


def split_item(item, source: str, error) -> tuple:
    """``"a.b=v"`` -> ``("a.b", parsed v)``."""
    if not isinstance(item, str) or "=" not in item:
        raise error(f"{source} {item!r}: expected key=value")
    key, text = (s.strip() for s in item.split("=", 1))
    return key, parse_value(text, f"{source} {item!r}", error)


def valid_keys(cls, prefix: str = "") -> list:
    """Every settable key of ``cls``: ``name`` for plain fields, ``name.<a|b|c>`` for nested configs."""
    out = []
    types = field_types(cls)
    for f in init_fields(cls):
        tp = types[f.name]
        if (f.metadata.get("spec") or Spec()).keys is not None:
            out.append(prefix + f.name)             # its sub-keys depend on the value: KeyGrammar.valid_keys
        elif dataclasses.is_dataclass(tp) and isinstance(tp, type):
            out.append(f"{prefix}{f.name}.<{'|'.join(g.name for g in init_fields(tp))}>")
        else:
            out.append(prefix + f.name)
    return out


def has_path(cls, key: str) -> bool:
    """Whether dotted ``key`` names a field of ``cls`` (through nested config dataclasses)."""
    head, _, rest = key.partition(".")
    types = field_types(cls)
    if head not in [f.name for f in init_fields(cls)]:
        return False
    tp = types[head]
    if rest and _field_spec(cls, head).keys is not None:
        return True                                 # checked against the value by its KeyGrammar
    return not rest or (dataclasses.is_dataclass(tp) and isinstance(tp, type) and has_path(tp, rest))


def _bare_fields(cls) -> list:
    return [f for f in init_fields(cls) if (f.metadata.get("spec") or Spec()).bare]


def resolve_key(obj, key: str) -> str:
    """``key`` as a field path of dataclass ``obj``: an alias of the class (its ``KEY_ALIASES`` mapping, e.g.
    ``image_noise`` -> ``noise.image_sigma``) replaced, and a key of a ``bare`` field's grammar given the
    field's name (``baseline`` -> ``rig.baseline``). Any other key is returned as it is."""
    cls = type(obj)
    key = getattr(cls, "KEY_ALIASES", {}).get(key, key)
    if key.partition(".")[0] in [f.name for f in init_fields(cls)]:
        return key
    for f in _bare_fields(cls):
        if f.metadata["spec"].keys.is_key(getattr(obj, f.name), key):
            return f"{f.name}.{key}"
    return key


def settable_keys(obj, prefix: str = "") -> list:
    """Every key :func:`replace_path` takes on ``obj``: :func:`valid_keys`, then the aliases, then the keys of
    the ``bare`` fields' grammars (which depend on their values)."""
    cls = type(obj)
    bare = [f.name for f in _bare_fields(cls)]
    own = [k for k in valid_keys(cls, prefix) if k[len(prefix):] not in bare]
    grammar = [k for f in _bare_fields(cls) for k in [prefix + f.name] + list(
        f.metadata["spec"].keys.valid_keys(getattr(obj, f.name)))]
    return own + list(getattr(cls, "KEY_ALIASES", {})) + grammar


def replace_path(obj, key: str, value, error, prefix: str = ""):
    """A copy of dataclass ``obj`` with the field at dotted ``key`` (resolved by :func:`resolve_key`) set to
    ``value``; the changed dataclasses are rebuilt, so their ``__post_init__`` checks run. Unknown keys name
    the valid ones (:func:`settable_keys`)."""
    key = resolve_key(obj, key)
    head, _, rest = key.partition(".")
    if head not in [f.name for f in init_fields(type(obj))]:
        raise error(f"{prefix}{key}: unknown key; valid keys: {', '.join(settable_keys(obj, prefix))}")
    if rest:
        child = getattr(obj, head)
        grammar = _field_spec(type(obj), head).keys
        if grammar is not None:
            return dataclasses.replace(obj, **{head: grammar.set_key(child, rest, value)})
        if not dataclasses.is_dataclass(child):
            raise error(f"{prefix}{key}: unknown key; {prefix}{head} has no sub-keys")
        value = replace_path(child, rest, value, error, f"{prefix}{head}.")
    else:                                           # checked here, so the error names the key as given
        value = check_value(value, field_types(type(obj))[head], _field_spec(type(obj), head), prefix + key, error)
    return dataclasses.replace(obj, **{head: value})


def apply_items(obj, items, error, source: str = "--set", prefix: str = "", setter=None):
    """``obj`` with each ``key=value`` string of ``items`` applied in order through :func:`replace_path`
    (e.g. an estimator config from ``--opt`` items), or ``setter(obj, key, value)`` (a :class:`KeyGrammar`'s
    ``set_key``); errors are one line ``<source> '<item>': <field>: ...``."""
    for item in [items] if isinstance(items, str) else items:
        key, value = split_item(item, source, error)
        try:
            obj = replace_path(obj, key, value, error, prefix) if setter is None else setter(obj, key, value)
        except TestbedError as exc:
            raise type(exc)(f"{source} {item!r}: {exc}") from None
    return obj
