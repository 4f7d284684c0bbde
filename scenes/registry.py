"""Scene registry: name -> class.  A new scene is one module plus one line in ``SCENES``.

A scene outside the package needs no edit here: ``"package.module:SceneClass"`` (a subclass of
:class:`scenes.base.Scene`, importable on ``sys.path``) works wherever a scene name does
(``--scene``, ``scene.name`` in a config file); see docs/extending.md."""
from __future__ import annotations

from rigs.plugins import load_plugin_class
from scenes.base import Scene, SceneConfig
from scenes.campus import CampusScene
from scenes.errors import SceneError
from scenes.indoor import IndoorScene
from scenes.lunar import LunarScene
from scenes.urban import UrbanScene

SCENES = {
    "campus": CampusScene,
    "indoor": IndoorScene,
    "lunar": LunarScene,
    "urban": UrbanScene,
}


def scene_names() -> tuple:
    return tuple(sorted(SCENES))


def scene_class(name: str) -> type:
    """The Scene class of a registered ``name`` or of a plug-in ``"package.module:SceneClass"``;
    anything else raises a one-line ``SceneError``."""
    if name in SCENES:
        return SCENES[name]
    if not isinstance(name, str) or ":" not in name:
        raise SceneError(f"unknown scene {name!r}; valid: {', '.join(scene_names())}, or 'package.module:SceneClass'")
    return load_plugin_class(name, Scene, "scene", SceneError)


def make_scene(config: SceneConfig, streams, dynamic=None) -> Scene:
    """Instantiate the scene ``config.name`` drawing from ``streams`` (key -> ``np.random.Generator``,
    e.g. ``sim.rng.scene_streams(seed)``); scenes with moving actors draw them from ``dynamic`` (the
    simulator's ``dynamic`` stream). Unknown names raise a one-line ``SceneError``."""
    cls = scene_class(config.name)
    return cls(config, streams, dynamic) if getattr(cls, "has_actors", False) else cls(config, streams)
