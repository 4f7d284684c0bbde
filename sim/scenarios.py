"""Named scenarios (scene, rig, duration, seed) and the on-disk cache of their datasets.

A scenario's dataset is cached under ``$VO_TESTBED_CACHE`` (default ``~/.cache/vo-testbed``)
in a folder named by the configuration hash, so ``vo-testbed check`` regenerates only when
the configuration (or the package version) changes.
"""
from __future__ import annotations

import os
from pathlib import Path

from sim.config import GenerateConfig
from sim.errors import SimError

SCENARIOS = {
    "campus": GenerateConfig(scene="campus", rig="cart27", duration_s=None, seed=0),
    "indoor": GenerateConfig(scene="indoor", rig="cart27", duration_s=None, seed=0),
    "campus-short": GenerateConfig(scene="campus", rig="cart27", duration_s=10.0, seed=0),
    "indoor-short": GenerateConfig(scene="indoor", rig="cart27", duration_s=8.0, seed=0),
    "campus-stereo27": GenerateConfig(scene="campus", rig="stereo27", duration_s=None, seed=0),
    "smoke": GenerateConfig(scene="indoor", rig="stereo27", duration_s=3.0, seed=0),
}

DEFAULT_SCENARIO = "campus"


def scenario_names() -> list:
    return sorted(SCENARIOS)


def get_scenario(name: str, overrides=(), seed=None) -> GenerateConfig:
    """The configuration of scenario ``name`` with extra ``key=value`` overrides and optional seed."""
    if name not in SCENARIOS:
        raise SimError(f"unknown scenario {name!r}; valid: {', '.join(scenario_names())}")
    base = SCENARIOS[name]
    changes = {}
    if overrides:
        changes["overrides"] = tuple(base.overrides) + tuple(overrides)
    if seed is not None:
        changes["seed"] = int(seed)
    return GenerateConfig(**{**base.to_dict(), **changes, "overrides": changes.get("overrides", base.overrides)})


def cache_root() -> Path:
    return Path(os.environ.get("VO_TESTBED_CACHE", Path.home() / ".cache" / "vo-testbed"))


def cached_dataset(config: GenerateConfig, progress: bool = True) -> Path:
    """Path of the dataset for ``config``, generating (or resuming) it when not complete."""
    from sim.generate import generate

    out = cache_root() / f"{config.scene}-{config.rig}-{config.config_hash()}"
    if (out / "metadata.yaml").exists() and not (out / "INCOMPLETE").exists():
        return out
    generate(config, out, progress=progress, overwrite=False)
    return out
