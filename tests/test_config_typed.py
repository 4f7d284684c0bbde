"""rigs.typed_config: dataclass fields typed by their annotations and checked by their knob specs, built
from mappings and changed by dotted keys with the same checks, every failure one line naming the field."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Optional

import numpy as np
import pytest

from rigs.errors import TestbedError
from rigs.typed_config import (apply_items, check_fields, from_mapping, has_path, knob, load_dataclass, replace_path,
                               split_item, to_mapping, valid_keys)


class ToyError(TestbedError):
    pass


@dataclass(frozen=True)
class Inner:
    gain: float = knob(1.0, gt=0.0, le=4.0)
    taps: int = knob(3, ge=1, odd=True)

    def __post_init__(self):
        check_fields(self, ToyError, "inner.")


@dataclass(frozen=True)
class Outer:
    mode: Literal["fast", "exact"] = "fast"
    on: bool = False
    count: int = knob(0, ge=0)
    limit: Optional[float] = knob(None, gt=0.0)
    freqs: tuple[float, ...] = (1.0,)
    label: str = "x"
    inner: Inner = knob(default_factory=Inner)
    scale: float | None = None

    def __post_init__(self):
        check_fields(self, ToyError)


@pytest.mark.parametrize("kw, message", [
    ({"on": "yes"}, "on: must be true or false, got 'yes'"),
    ({"on": 1}, "on: must be true or false, got 1"),
    ({"count": True}, "count: must be an integer, got True"),
    ({"count": 2.5}, "count: must be an integer, got 2.5"),
    ({"count": -1}, "count: must be a non-negative number, got -1"),
    ({"limit": math.nan}, "limit: must be a finite number, got nan"),
    ({"limit": math.inf}, "limit: must be a finite number, got inf"),
    ({"limit": "3"}, "limit: must be a finite number, got '3'"),
    ({"limit": 0}, "limit: must be a positive number, got 0.0"),
    ({"mode": "slow"}, "mode: unknown 'slow'; valid: fast, exact"),
    ({"freqs": [1, "a"]}, "freqs[1]: must be a finite number, got 'a'"),
    ({"freqs": 3}, "freqs: expected a list, got 3"),
    ({"label": ""}, "label: must be a non-empty string, got ''"),
    ({"inner": {"gain": 5}}, "inner.gain: must be in (0, 4], got 5.0"),
    ({"inner": {"taps": 2}}, "inner.taps: must be odd, got 2"),
    ({"inner": {"tap": 3}}, "inner.tap: unknown key; valid keys: gain, taps"),
    ({"inner": 7}, "inner: expected a mapping with keys gain, taps, got 7"),
])
def test_bad_values_are_one_line_naming_the_field(kw, message):
    with pytest.raises(ToyError) as e:
        Outer(**kw)
    assert str(e.value) == message


def test_bounds_are_described_in_words_or_intervals():
    from rigs.typed_config import Spec
    assert Spec(ge=0).describe() == "a non-negative number" and Spec(gt=0).describe() == "a positive number"
    assert Spec(ge=1).describe() == ">= 1" and Spec(lt=2.5).describe() == "< 2.5"
    assert Spec(gt=0.0, le=4.0).describe() == "in (0, 4]" and Spec(ge=1, lt=7).describe() == "in [1, 7)"
    assert Spec(ge=0).problem(0) is None and Spec(ge=0).problem(-1) == "must be a non-negative number, got -1"


def test_values_are_coerced_to_their_annotated_types():
    o = Outer(count=np.int64(3), limit=2, freqs=[1, 2.5], inner={"gain": 2, "taps": 5.0}, on=np.bool_(True))
    assert o == Outer(count=3, limit=2.0, freqs=(1.0, 2.5), inner=Inner(gain=2.0, taps=5), on=True)
    assert type(o.count) is int and type(o.limit) is float and type(o.inner.taps) is int and type(o.on) is bool
    assert Outer(limit="none").limit is None and Outer(limit=None).limit is None
    assert Outer(scale=2).scale == 2.0 and Outer(scale=None).scale is None
    with pytest.raises(ToyError, match="^scale: must be a finite number, got 'big'$"):
        Outer(scale="big")


def test_mapping_round_trip_and_unknown_keys():
    o = Outer(mode="exact", limit=1.5, freqs=(0.5, 2.0), inner=Inner(gain=3.0))
    d = to_mapping(o)
    assert d == {"mode": "exact", "on": False, "count": 0, "limit": 1.5, "freqs": [0.5, 2.0], "label": "x",
                 "inner": {"gain": 3.0, "taps": 3}, "scale": None}
    assert from_mapping(Outer, d, ToyError) == o and from_mapping(Outer, None, ToyError) == Outer()
    with pytest.raises(ToyError, match="^cout: unknown key; valid keys: mode, on, count, limit, freqs, label, inner, scale$"):
        from_mapping(Outer, {"cout": 1}, ToyError)
    with pytest.raises(ToyError, match="^<top>: expected a mapping of field names, got list$"):
        from_mapping(Outer, [1], ToyError)


def test_dotted_keys_run_the_same_checks():
    o = Outer()
    assert replace_path(o, "inner.gain", 2, ToyError).inner.gain == 2.0
    assert replace_path(o, "count", 4, ToyError).count == 4 and o.count == 0          # o unchanged (frozen)
    with pytest.raises(ToyError, match=r"^inner.gain: must be in \(0, 4\], got 9.0$"):
        replace_path(o, "inner.gain", 9, ToyError)
    with pytest.raises(ToyError, match="^inner.gian: unknown key; valid keys: inner.gain, inner.taps$"):
        replace_path(o, "inner.gian", 1, ToyError)
    with pytest.raises(ToyError, match=r"^label.x: unknown key; label has no sub-keys$"):
        replace_path(o, "label.x", 1, ToyError)
    assert valid_keys(Outer) == ["mode", "on", "count", "limit", "freqs", "label", "inner.<gain|taps>", "scale"]
    assert has_path(Outer, "inner.taps") and not has_path(Outer, "inner.x") and not has_path(Outer, "label.x")


def test_apply_items_for_option_lists():
    o = apply_items(Outer(), ["mode=exact", "inner.gain=0.5", "freqs=[3, 4]"], ToyError, "--opt")
    assert o == Outer(mode="exact", inner=Inner(gain=0.5), freqs=(3.0, 4.0))
    with pytest.raises(ToyError, match=r"^--opt 'inner.taps=4': inner.taps: must be odd, got 4$"):
        apply_items(o, ["count=1", "inner.taps=4"], ToyError, "--opt")


def test_split_item_parses_yaml_values():
    assert split_item("a.b=1e-4", "--set", ToyError) == ("a.b", 1e-4)
    assert split_item("on = true", "--set", ToyError) == ("on", True)
    assert split_item("freqs=[1, 2]", "--set", ToyError) == ("freqs", [1, 2])
    with pytest.raises(ToyError, match="^--set 'x': expected key=value$"):
        split_item("x", "--set", ToyError)


def test_load_dataclass_names_the_file(tmp_path):
    f = tmp_path / "o.yaml"
    f.write_text("inner: {gain: 2}\nmode: exact\n")
    assert load_dataclass(Outer, f, ToyError) == Outer(mode="exact", inner=Inner(gain=2.0))
    f.write_text("inner: {gain: -1}\n")
    with pytest.raises(ToyError, match=rf"^{f}: inner.gain: must be in \(0, 4\], got -1.0$"):
        load_dataclass(Outer, f, ToyError)
    f.write_text("mode: [\n")
    with pytest.raises(ToyError, match=rf"^{f}: YAML syntax error"):
        load_dataclass(Outer, f, ToyError)
    with pytest.raises(ToyError, match="cannot read file"):
        load_dataclass(Outer, tmp_path / "missing.yaml", ToyError)


@dataclass(frozen=True)
class Mount:
    """A required field (no default), a field a mapping must state (``required``), a ``check`` hook."""
    name: str
    offset: tuple[float, float] = knob((1.0, 0.0), required=True, check=lambda v: "must be on the unit circle"
                                        if not math.isclose(math.hypot(*v), 1.0) else None)

    def __post_init__(self):
        check_fields(self, ToyError, f"mount {self.name!r}.")


@dataclass(frozen=True)
class Holder:
    KEY_ALIASES = {"first": "mounts"}       # not a field: a short key resolve_key replaces
    mounts: tuple[Mount, ...] = ()

    def __post_init__(self):
        check_fields(self, ToyError)


def test_mappings_name_missing_and_checked_fields_by_their_path():
    ok = from_mapping(Holder, {"mounts": [{"name": "a", "offset": [0.6, 0.8]}]}, ToyError)
    assert ok.mounts == (Mount("a", (0.6, 0.8)),)
    for data, message in (({"mounts": [{"offset": [1, 0]}]}, "mounts[0].name: missing field"),
                          ({"mounts": [{"name": "a"}]}, "mounts[0].offset: missing field"),
                          ({"mounts": [{"name": "a", "offset": [1, 1]}]}, "mounts[0].offset: must be on the unit "),
                          ({"mounts": [{"name": "a", "offset": [1]}]}, "mounts[0].offset: expected a list of 2 ")):
        with pytest.raises(ToyError) as e:
            from_mapping(Holder, data, ToyError)
        assert str(e.value).startswith(message), str(e.value)
    assert Mount("b").offset == (1.0, 0.0)                    # code may leave a "required" field at its default
    with pytest.raises(ToyError, match=r"^mount 'c'\.offset: must be on the unit circle"):
        Mount("c", (2.0, 0.0))


def test_aliases_resolve_to_their_field():
    h = replace_path(Holder(), "first", [{"name": "a", "offset": [0.0, 1.0]}], ToyError)
    assert h.mounts[0].offset == (0.0, 1.0)
    with pytest.raises(ToyError, match="^frist: unknown key; valid keys: mounts, first$"):
        replace_path(Holder(), "frist", [], ToyError)
