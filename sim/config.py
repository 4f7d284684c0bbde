"""Generation configuration: one frozen dataclass, loadable from YAML, overridable with ``key=value``."""
from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from typing import Optional

import yaml

from sim.errors import SimError

MAX_SUPERSAMPLE = 7


def check_supersample(value) -> int:
    """Validated supersampling factor (``render.supersample``): an odd integer 1..MAX_SUPERSAMPLE (odd, so
    every output pixel centre is the centre of one rendered sub-pixel: depth and segmentation stay exact)."""
    ok = isinstance(value, int) and not isinstance(value, bool)
    if not ok or not 1 <= value <= MAX_SUPERSAMPLE or value % 2 == 0:
        raise SimError(f"render.supersample: {value!r}; must be an odd integer in 1..{MAX_SUPERSAMPLE}")
    return int(value)

FORMATS = ("euroc", "kitti", "both")


@dataclass(frozen=True)
class GenerateConfig:
    """Everything that determines a generated dataset (together with the package version).

    ``overrides`` are ``key=value`` strings: ``scene.*`` keys go to the scene
    (``scene.texture_richness=0.3``), ``motion.*`` keys to the vehicle motion, ``image_noise=2``
    sets the image noise sigma (grey levels); anything else is a rig override
    (``baseline=0.063``, ``imu.rate_hz=400``, ``imu=paper002``).
    """

    scene: str = "campus"
    rig: str = "cart27"
    duration_s: Optional[float] = None
    seed: int = 0
    format: str = "euroc"
    depth: bool = False
    segmentation: bool = False
    ideal: bool = False
    images: bool = True
    vehicle: str = "cart"
    image_noise: float = 1.0
    rgb: bool = False
    overrides: tuple = field(default_factory=tuple)

    def __post_init__(self):
        if self.format not in FORMATS:
            raise SimError(f"format: unknown {self.format!r}; valid: {', '.join(FORMATS)}")
        if self.duration_s is not None and not float(self.duration_s) > 0:
            raise SimError(f"duration_s: must be positive, got {self.duration_s!r}")
        if float(self.image_noise) < 0:
            raise SimError(f"image_noise: must be >= 0, got {self.image_noise!r}")
        if isinstance(self.seed, bool) or int(self.seed) != self.seed or self.seed < 0:
            raise SimError(f"seed: must be a non-negative integer, got {self.seed!r}")
        object.__setattr__(self, "overrides", tuple(str(o) for o in self.overrides))
        for o in self.overrides:
            if "=" not in o:
                raise SimError(f"overrides: expected key=value, got {o!r}")
        self.split_overrides()          # validates the values it interprets (render.supersample)

    def split_overrides(self) -> dict:
        """-> {"scene": {key: value}, "motion": {...}, "rig": [k=v, ...], "image_noise": float|None,
        "supersample": int} (``render.supersample=S``: see :mod:`sim.render`)."""
        out = {"scene": {}, "motion": {}, "rig": [], "image_noise": None, "supersample": 1}
        for o in self.overrides:
            key, _, raw = o.partition("=")
            value = yaml.safe_load(raw)
            if key.startswith("scene."):
                out["scene"][key[6:]] = value
            elif key.startswith("motion."):
                out["motion"][key[7:]] = value
            elif key == "image_noise":
                out["image_noise"] = float(value)
            elif key == "render.supersample":
                out["supersample"] = check_supersample(value)
            else:
                out["rig"].append(o)
        return out

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["overrides"] = list(self.overrides)
        return d

    def config_hash(self) -> str:
        """Stable hash of the configuration (for caching generated scenarios)."""
        from sim import __version__
        blob = json.dumps({"config": self.to_dict(), "version": __version__}, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


def load_generate_config(path) -> GenerateConfig:
    """Load a :class:`GenerateConfig` from YAML whose keys are the field names."""
    from rigs.io_yaml import load_dataclass
    return load_dataclass(GenerateConfig, path, SimError)
