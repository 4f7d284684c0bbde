"""Scene interface: static geometry, route, ground check points, ground height.

A scene owns its MuJoCo subtree (added through :meth:`Scene.add_to_spec`) and its route.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass

import numpy as np

from scenes.errors import SceneError


@dataclass(frozen=True)
class SceneConfig:
    """Knobs common to every scene; every field can be overridden from the CLI."""

    name: str = "campus"
    seed: int = 0
    texture_richness: float = 0.8   # 0 = flat colours, 1 = rich texture
    lighting: float = 1.0           # overall light intensity scale (0.2 .. 2)
    shadows: bool = False           # shadow casting (costly on CPU rendering)

    def __post_init__(self):
        if not 0.0 <= float(self.texture_richness) <= 1.0:
            raise SceneError(f"scene.texture_richness: must be in [0, 1], got {self.texture_richness!r}")
        if not 0.0 < float(self.lighting) <= 4.0:
            raise SceneError(f"scene.lighting: must be in (0, 4], got {self.lighting!r}")


@dataclass(frozen=True)
class Route:
    """Where the vehicle drives: waypoints in the world x-y plane and a speed profile."""

    waypoints_xy: tuple          # ((x, y), ...) metres
    closed: bool = False         # loop back to the first waypoint
    cruise_speed_mps: float = 1.2
    accel_mps2: float = 0.4      # start/stop acceleration magnitude

    def __post_init__(self):
        wp = np.asarray(self.waypoints_xy, dtype=float)
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise SceneError(f"route.waypoints_xy: expected at least two (x, y) points, got shape {wp.shape}")
        if self.cruise_speed_mps <= 0 or self.accel_mps2 <= 0:
            raise SceneError("route.cruise_speed_mps and route.accel_mps2 must be positive")

    @property
    def xy(self) -> np.ndarray:
        return np.asarray(self.waypoints_xy, dtype=float)


@dataclass(frozen=True)
class GcpSite:
    """A ground check point on the route, by name and planar position (z from the terrain)."""

    name: str
    x: float
    y: float


class Scene(abc.ABC):
    """A procedurally generated, seeded scene."""

    name: str = ""

    def __init__(self, config: SceneConfig):
        self.config = config

    @property
    @abc.abstractmethod
    def route(self) -> Route:
        """The vehicle's route."""

    @property
    @abc.abstractmethod
    def gcp_sites(self) -> tuple:
        """``GcpSite`` tuple along the route."""

    def ground_height(self, x, y) -> np.ndarray:
        """Terrain height z (m) at world (x, y); vectorised. Flat by default."""
        return np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)

    @abc.abstractmethod
    def add_to_spec(self, spec) -> None:
        """Add the scene's static geometry, textures, materials and lights to a ``mujoco.MjSpec``."""

    def extent_xy(self) -> tuple:
        """(xmin, xmax, ymin, ymax) for top-down plots."""
        xy = self.route.xy
        return (xy[:, 0].min() - 10, xy[:, 0].max() + 10, xy[:, 1].min() - 10, xy[:, 1].max() + 10)
