"""Where the testbed keeps what it can make again: ``$VO_TESTBED_CACHE``, default ``~/.cache/vo-testbed``
(scenario datasets under their config hash, :mod:`sim.scenarios`; textures, :mod:`sim.texture_cache`; compiled
worlds, :mod:`sim.world_cache`)."""
from __future__ import annotations

import os
from pathlib import Path


def cache_root() -> Path:
    """The cache folder (not created here)."""
    return Path(os.environ.get("VO_TESTBED_CACHE", Path.home() / ".cache" / "vo-testbed"))
