"""Scene registry: name -> class.  A new scene is one module plus one line in ``SCENES``."""
from __future__ import annotations

from scenes.base import Scene, SceneConfig
from scenes.campus import CampusScene
from scenes.errors import SceneError
from scenes.indoor import IndoorScene

SCENES = {
    "campus": CampusScene,
    "indoor": IndoorScene,
}


def scene_names() -> tuple:
    return tuple(sorted(SCENES))


def make_scene(config: SceneConfig) -> Scene:
    """Instantiate the scene ``config.name``; unknown names raise a one-line ``SceneError``."""
    cls = SCENES.get(config.name)
    if cls is None:
        raise SceneError(f"unknown scene {config.name!r}; valid: {', '.join(scene_names())}")
    return cls(config)
