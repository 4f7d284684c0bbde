"""Common base of the procedural scenes built with :class:`scenes.builder.SceneBuilder`."""
from __future__ import annotations

import abc
from typing import Callable

import numpy as np

from scenes.base import Scene, SceneConfig
from scenes.errors import SceneError
from scenes.routes import polyline_length


class BuiltScene(Scene):
    """A scene whose geometry is produced by ``_build(builder)``; keeps footprints and geom ids.

    Subclasses set ``corridor_half_width_m`` / ``corridor_height_m`` (free space around the route
    that no geom enters) and implement ``route``, ``gcp_sites``, ``path_xy`` and ``_build``.
    ``streams`` is the random-stream factory the scene receives (key -> ``np.random.Generator``;
    the simulator passes ``sim.rng.scene_streams(seed)``): layout draws from ``<scene>/<purpose>``,
    textures from ``texture/<kind>/<variant>``.
    """

    corridor_half_width_m: float = 1.5
    corridor_height_m: float = 3.0

    def __init__(self, config: SceneConfig, streams: Callable[[str], np.random.Generator]):
        super().__init__(config)
        if not callable(streams):
            raise SceneError(f"scene {self.name!r}: streams must be a callable key -> numpy Generator, "
                             f"got {type(streams).__name__}")
        self.streams = streams
        self._footprints = None
        self._object_ids = None
        self.texture_bytes = 0

    def rng(self, purpose: str) -> np.random.Generator:
        """The generator of one layout purpose: stream key ``<scene>/<purpose>``."""
        return self.streams(f"{self.name}/{purpose}")

    @property
    @abc.abstractmethod
    def path_xy(self) -> np.ndarray:
        """Dense (N, 2) polyline of the route centre line (m), the curve the waypoints sample."""

    def route_length(self) -> float:
        return polyline_length(self.path_xy, closed=self.route.closed)

    @abc.abstractmethod
    def _build(self, b) -> None:
        """Add everything through the ``SceneBuilder`` ``b``."""

    def add_to_spec(self, spec, textures=None) -> None:
        from scenes.builder import SceneBuilder   # mujoco only when building
        c = self.config
        b = SceneBuilder(spec, self.streams, c.texture_richness, c.lighting, c.shadows, textures=textures)
        self._build(b)
        self._footprints = list(b.footprints)
        self._object_ids = b.object_ids()
        self.texture_bytes = b.texture_bytes

    def built_state(self) -> dict:
        """What :meth:`add_to_spec` learnt beside the MuJoCo model (footprints, geom ids, texture bytes), for a
        process that loads the compiled model instead of building it (:meth:`adopt_built_state`)."""
        self._ensure_built()
        return {"footprints": list(self._footprints), "object_ids": dict(self._object_ids),
                "texture_bytes": int(self.texture_bytes)}

    def adopt_built_state(self, state: dict) -> None:
        """Take :meth:`built_state` of a build of this very scene (same config and streams) as this one's."""
        self._footprints, self._object_ids = list(state["footprints"]), dict(state["object_ids"])
        self.texture_bytes = int(state["texture_bytes"])

    def _ensure_built(self):
        if self._footprints is None:
            import mujoco
            self.add_to_spec(mujoco.MjSpec())

    def footprints(self) -> list:
        """Top-down ``Footprint`` list of every static geom (builds a throw-away spec if needed)."""
        self._ensure_built()
        return list(self._footprints)

    def object_ids(self) -> dict:
        """Geom name -> stable int id (1-based, sorted by name) for segmentation images."""
        self._ensure_built()
        return dict(self._object_ids)
