"""Scene interface: static geometry, route, ground check points, ground height.

A scene owns its MuJoCo subtree (added through :meth:`Scene.add_to_spec`) and its route.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Literal, Optional

import numpy as np

from rigs.typed_config import check_fields, knob
from scenes.errors import SceneError


@dataclass(frozen=True)
class SceneConfig:
    """Knobs common to every scene; YAML and ``--set scene.<field>`` keys are the field names, each
    value type- and range-checked on construction (:mod:`rigs.typed_config`). A new knob is one field."""

    name: str = "campus"
    seed: Optional[int] = knob(0, ge=0, doc="scene randomness; None inside a GenerateConfig: its seed")
    texture_richness: float = knob(0.8, ge=0.0, le=1.0, doc="0 = flat colours, 1 = rich texture")
    lighting: float = knob(1.0, gt=0.0, le=4.0, doc="overall light intensity scale")
    shadows: Optional[bool] = knob(None, doc="shadow casting (costly on CPU rendering); None: the scene's "
                                   "default (on for lunar, off elsewhere)")
    dynamic_density: float = knob(0.5, ge=0.0, le=1.0, doc="fraction of the scene's actors that move (0 = none)")
    time_of_day: Literal["day", "dusk"] = knob("day", doc="dusk: low warm sun, dim ambient (scenes that support it)")
    sun_elevation_deg: float = knob(12.0, gt=0.0, le=90.0, doc="sun elevation (lunar): low sun, long shadows")
    sun_azimuth_deg: float = knob(135.0, ge=-360.0, le=360.0, doc="sun azimuth (lunar), deg counter-clockwise from east")

    def __post_init__(self):
        check_fields(self, SceneError, "scene.")


@dataclass(frozen=True)
class Route:
    """Where the vehicle drives: waypoints in the world x-y plane and a speed profile."""

    waypoints_xy: tuple          # ((x, y), ...) metres
    closed: bool = False         # loop back to the first waypoint
    cruise_speed_mps: float = 1.2
    accel_mps2: float = 0.4      # start/stop acceleration magnitude
    stops_m: tuple = ()          # arc lengths (m) where the vehicle comes to rest on the way
    stop_dwell_s: float = 0.0    # time at rest at each of ``stops_m``

    def __post_init__(self):
        wp = np.asarray(self.waypoints_xy, dtype=float)
        if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
            raise SceneError(f"route.waypoints_xy: expected at least two (x, y) points, got shape {wp.shape}")
        if self.cruise_speed_mps <= 0 or self.accel_mps2 <= 0:
            raise SceneError("route.cruise_speed_mps and route.accel_mps2 must be positive")
        if any(not 0 < float(s) for s in self.stops_m) or list(self.stops_m) != sorted(self.stops_m) \
                or self.stop_dwell_s < 0 or (self.stops_m and self.closed):
            raise SceneError(f"route.stops_m: need increasing positive arc lengths on an open route and "
                             f"stop_dwell_s >= 0, got {self.stops_m!r}, {self.stop_dwell_s!r}")

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

    def actor_states(self, t_ns: int) -> dict:
        """Poses ``{mocap body name: (4,4) T_w_x}`` of the scene's moving actors at ``t_ns``; none by default."""
        return {}

    def actor_truth(self, t_ns) -> list:
        """``[(actor_id, kind, moving, T_w_x (N,4,4))]`` of every actor at ``t_ns`` (N,); none by default."""
        return []

    def first_contact(self, t_ns, T_w_b, footprint) -> Optional[tuple]:
        """``(t_ns, actor_id, kind)`` of the first of the times ``t_ns`` (N,) at which the vehicle, at poses
        ``T_w_b`` (N,4,4) with ``footprint`` ``(x_centre_b, half_length, half_width)`` (m), touches a solid
        actor, or None; scenes without actors never touch."""
        return None

    def segmentation_rows(self, geom_names) -> list:
        """``(seg_id, geom_name, actor_id, kind, moving)`` per geom ``g`` (``seg_id = g + 1``, as the segmentation
        PNGs store it); without actors every geom is ``static`` (or ``dynamic`` for a ``dyn/`` geom), actor -1."""
        return [(g + 1, n or "", -1, "dynamic" if (n or "").startswith("dyn/") else "static", 0)
                for g, n in enumerate(geom_names)]

    def ground_height(self, x, y) -> np.ndarray:
        """Terrain height z (m) at world (x, y); vectorised. Flat by default."""
        return np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)

    @abc.abstractmethod
    def add_to_spec(self, spec, textures=None) -> None:
        """Add the scene's static geometry, textures, materials and lights to a ``mujoco.MjSpec``; ``textures``:
        a :class:`scenes.texture_store.TextureStore` that keeps drawn textures between processes (None: draw)."""

    def extent_xy(self) -> tuple:
        """(xmin, xmax, ymin, ymax) for top-down plots."""
        xy = self.route.xy
        return (xy[:, 0].min() - 10, xy[:, 0].max() + 10, xy[:, 1].min() - 10, xy[:, 1].max() + 10)
