"""Scene definitions and procedural texture/terrain generators (seeded; nothing downloaded)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering unless the user chose otherwise
from scenes.base import GcpSite, Route, Scene, SceneConfig
from scenes.errors import SceneError
from scenes.registry import SCENES, make_scene, scene_names

__all__ = ["GcpSite", "Route", "Scene", "SceneConfig", "SceneError", "SCENES", "make_scene", "scene_names"]
