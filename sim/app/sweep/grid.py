"""Sweep specification: a scenario, grid axes (any ``--set`` key), estimators and seeds -> cells.

A cell is one grid point at one seed: one generated dataset, every estimator run on it. Its key is
the hash of its resolved :class:`~sim.generate_config.GenerateConfig` (:meth:`config_hash`), so the same
configuration always lands in the same result file, whichever machine or worker runs it. Every
grid value is applied through :meth:`GenerateConfig.with_overrides` when the cells are built, so a
bad key or value is a one-line :class:`SweepError` before anything runs.

YAML spec file (keys = :class:`SweepSpec` field names)::

    scenario: campus-short
    grid: {baseline: [0.063, 0.12, 0.27, 0.5], scene.texture_richness: [0.1, 0.3, 0.6, 1.0]}
    estimators: [rop, klt-pnp]
    seeds: "0:5"            # or a list [0, 1, 2, 3, 4]
    set: [duration_s=4]     # fixed overrides applied to every cell before the grid values
"""
from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Optional

from rigs.config_io import parse_yaml_text, read_yaml_file
from rigs.errors import TestbedError
from sim.errors import SimError
from sim.generate_config import GenerateConfig
from sim.scenarios import SCENARIOS, get_scenario, scenario_names
from vo.estimators.registry import check_spec


class SweepError(SimError):
    """A bad sweep specification (grid axis, seeds, estimator, spec file)."""


@dataclass(frozen=True)
class Cell:
    """One grid point at one seed: ``values`` maps axis key -> value; ``config`` is resolved."""

    key: str
    values: tuple            # ((axis key, value), ...) in axis order
    seed: int
    config: GenerateConfig = field(repr=False)

    @property
    def overrides(self) -> list:
        return [f"{k}={v}" for k, v in self.values]


@dataclass(frozen=True)
class SweepSpec:
    """What to sweep. ``axes``: ((key, (values...)), ...); ``overrides``: fixed ``--set`` items."""

    scenario: str
    axes: tuple
    estimators: tuple
    seeds: tuple
    overrides: tuple = ()

    def __post_init__(self):
        if not self.axes:
            raise SweepError("--grid: give at least one axis KEY=V1,V2,...")
        keys = [k for k, _ in self.axes]
        dup = sorted({k for k in keys if keys.count(k) > 1})
        if dup:
            raise SweepError(f"--grid {dup[0]!r}: axis given twice")
        for k, vals in self.axes:
            if not vals:
                raise SweepError(f"--grid {k!r}: no values")
        if not self.estimators:
            raise SweepError("--estimator: give at least one estimator")
        if not self.seeds or any(s < 0 for s in self.seeds) or len(set(self.seeds)) != len(self.seeds):
            raise SweepError(f"--seeds: expected distinct non-negative seeds, got {list(self.seeds)!r}")
        for name in self.estimators:
            try:
                check_spec(name)
            except TestbedError as exc:
                raise SweepError(f"--estimator {name!r}: {exc}") from None

    @property
    def axis_keys(self) -> list:
        return [k for k, _ in self.axes]

    def cells(self) -> list:
        """Every (grid point, seed), configuration resolved and validated (SweepError naming the item)."""
        base = self.base_config()
        out = []
        for combo in itertools.product(*[vals for _, vals in self.axes]):
            values = tuple(zip(self.axis_keys, combo))
            items = [f"{k}={v}" for k, v in values]
            try:
                point = base.with_overrides(items, source="--grid")
            except TestbedError as exc:
                raise SweepError(str(exc)) from None
            for seed in self.seeds:
                cfg = point.with_value("seed", seed)
                out.append(Cell(cfg.config_hash(), values, seed, cfg))
        return out

    def base_config(self) -> GenerateConfig:
        if self.scenario not in SCENARIOS:
            raise SweepError(f"--scenario {self.scenario!r}: unknown scenario; valid: {', '.join(scenario_names())}")
        try:
            return get_scenario(self.scenario, self.overrides, source="--set")
        except TestbedError as exc:
            raise SweepError(str(exc)) from None

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "grid": {k: list(v) for k, v in self.axes},
                "estimators": list(self.estimators), "seeds": list(self.seeds), "set": list(self.overrides)}


def parse_axis(text: str) -> tuple:
    """``"baseline=0.063,0.12"`` -> ``("baseline", (0.063, 0.12))`` (each value parsed as YAML)."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key or not raw.strip():
        raise SweepError(f"--grid {text!r}: expected KEY=V1,V2,...")
    values = tuple(parse_yaml_text(v.strip(), f"--grid {text!r}", SweepError) for v in raw.split(","))
    if any(v is None or v == "" for v in values):
        raise SweepError(f"--grid {text!r}: empty value")
    return key, values


def parse_seeds(text) -> tuple:
    """``"0:5"`` (start:stop, stop excluded, like range) or ``"0,3,7"`` or a list -> seeds."""
    if isinstance(text, (list, tuple)):
        items = list(text)
    elif isinstance(text, int) and not isinstance(text, bool):
        items = [text]
    else:
        s = str(text).strip()
        try:
            if ":" in s:
                a, b = (int(p) for p in s.split(":"))
                items = list(range(a, b))
            else:
                items = [int(p) for p in s.split(",") if p.strip()]
        except ValueError:
            raise SweepError(f"--seeds: expected 'start:stop' or '0,3,7', got {text!r}") from None
    if not items or not all(isinstance(v, int) and not isinstance(v, bool) for v in items):
        raise SweepError(f"--seeds: expected 'start:stop' (stop excluded) or '0,3,7', got {text!r}")
    return tuple(items)


def parse_estimators(texts) -> tuple:
    """``("rop,klt-pnp", "orb-pnp")`` -> ``("rop", "klt-pnp", "orb-pnp")``."""
    out = []
    for t in [texts] if isinstance(texts, str) else texts:
        out += [p.strip() for p in str(t).split(",") if p.strip()]
    return tuple(dict.fromkeys(out))


def spec_from_cli(scenario: str, grid: tuple, estimators, seeds: str, overrides=()) -> SweepSpec:
    return SweepSpec(scenario, tuple(parse_axis(g) for g in grid), parse_estimators(estimators),
                     parse_seeds(seeds), tuple(overrides))


def load_spec(path, scenario: Optional[str] = None) -> SweepSpec:
    """A :class:`SweepSpec` from a YAML file (module docstring); ``scenario`` overrides the file's."""
    data = read_yaml_file(path, SweepError)
    names = {"scenario", "grid", "estimators", "seeds", "set"}
    if not isinstance(data, Mapping):
        raise SweepError(f"{path}: expected a mapping with keys {', '.join(sorted(names))}")
    unknown = sorted(set(data) - names)
    if unknown:
        raise SweepError(f"{path}: {unknown[0]}: unknown key; valid keys: {', '.join(sorted(names))}")
    grid = data.get("grid") or {}
    if not isinstance(grid, Mapping) or not all(isinstance(v, list) for v in grid.values()):
        raise SweepError(f"{path}: grid: expected a mapping KEY: [values], got {grid!r}")
    try:
        return SweepSpec(scenario or data.get("scenario") or "campus-short",
                         tuple((str(k), tuple(v)) for k, v in grid.items()),
                         parse_estimators(data.get("estimators") or ()), parse_seeds(data.get("seeds", "0:1")),
                         tuple(str(s) for s in data.get("set") or ()))
    except TestbedError as exc:
        raise SweepError(f"{path}: {exc}") from None
