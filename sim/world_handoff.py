"""A compiled world handed from one process to others: built once, loaded by each render process.

Building a world (:func:`sim.world.build_world`) is most of a render process's start-up: the scene's
procedural geometry and textures (``Scene.add_to_spec``: 0.6 CPU s on campus-short, 7.6 on
urban-dynamic) and the lens-distortion maps (0.6 s on campus-short's rig); MuJoCo's compile itself is a
tenth of that. :func:`save_world` writes the compiled model as MuJoCo's binary model file (``mj_saveModel``,
an exact image of ``mjModel``) and the parts the model does not hold (the vehicle's element names, the
render rig with its pinhole canvases, the distortion maps) as a pickle, into a folder; :func:`load_world`
makes a :class:`sim.world.World` from them in another process (``MjModel.from_binary_path``), for the
scene and rig that process resolved from the same configuration. The model's bytes are those the other
process would have compiled, so its renders are the same (``tests/test_generate_pipeline.py``: multi-process
runs byte-identical to the serial loop).

The scene object of the loading process is the resolved, unbuilt one: the renderer reads only the model,
and actor poses (``Scene.actor_states``) come from the scene's construction, not its build. What the build
learns beside the model (a :class:`scenes.built.BuiltScene`'s footprints and geom ids, ``built_state``) is
saved too and given to the loading process's scene (``adopt_built_state``), which then needs no build for its
top-down map (:mod:`sim.world_cache` loads worlds in place of building them).
"""
from __future__ import annotations

import os
import pickle
from dataclasses import dataclass

from sim.errors import SimError
from sim.world import World

MODEL_FILE = "world.mjb"
PARTS_FILE = "world_parts.pkl"


@dataclass(frozen=True)
class WorldFiles:
    """Where :func:`save_world` put a world: ``folder`` with :data:`MODEL_FILE` and :data:`PARTS_FILE`,
    for the configuration whose ``config_hash()`` is ``key``."""
    folder: str
    key: str


def save_world(world, folder, key: str) -> WorldFiles:
    """Write ``world`` (:class:`sim.world.World`) into the existing ``folder``; ``key`` names the
    configuration it was built for (a loader checks it)."""
    import mujoco
    folder = os.fspath(folder)
    mujoco.mj_saveModel(world.model, os.path.join(folder, MODEL_FILE), None)
    with open(os.path.join(folder, PARTS_FILE), "wb") as f:
        built = getattr(world.scene, "built_state", None)       # what the scene's build learnt beside the model
        pickle.dump({"handles": world.handles, "render_rig": world.render_rig, "maps": world.distortion_maps,
                     "rig": world.rig, "scene_state": built() if built else None}, f, protocol=pickle.HIGHEST_PROTOCOL)
    return WorldFiles(folder, str(key))


def load_world(files: WorldFiles, scene, rig):
    """The :class:`sim.world.World` saved in ``files``, for ``scene`` and ``rig`` (the rig it was built with:
    a different one is a one-line :class:`sim.errors.SimError`)."""
    import mujoco
    path = os.path.join(files.folder, MODEL_FILE)
    if not os.path.isfile(path):             # checked here: MuJoCo would also write MUJOCO_LOG.TXT
        raise SimError(f"{files.folder}: cannot load the saved world (no {MODEL_FILE})")
    try:
        model = mujoco.MjModel.from_binary_path(path)
        with open(os.path.join(files.folder, PARTS_FILE), "rb") as f:
            parts = pickle.load(f)
    except (OSError, ValueError, pickle.UnpicklingError) as exc:
        raise SimError(f"{files.folder}: cannot load the saved world ({exc})") from None
    if parts["rig"] != rig:
        raise SimError(f"{files.folder}: the saved world carries rig {parts['rig'].name!r}, not {rig.name!r}")
    if parts.get("scene_state") is not None and hasattr(scene, "adopt_built_state"):
        scene.adopt_built_state(parts["scene_state"])     # footprints for the top-down map, without a build
    return World(model, rig, parts["handles"], scene, parts["render_rig"], parts["maps"])
