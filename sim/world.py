"""Build the MuJoCo world (scene + vehicle + rig cameras) and pose the vehicle.

Rendering quality is set for speed on CPU (llvmpipe): no MSAA, shadows only if the scene asks
(``scene.config.shadows``; otherwise every light's ``castshadow`` is cleared so no shadow pass
runs), no reflections. MuJoCo's clip planes are ``znear * stat.extent`` and ``zfar * stat.extent``;
we fix ``stat.extent`` to :data:`EXTENT_M` and set the map values so the absolute planes are
:data:`ZNEAR_M` and :data:`ZFAR_M`.
"""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before the first mujoco import (headless)

from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Callable, Optional

import mujoco  # noqa: E402
import numpy as np

from rigs.geometry import quat_wxyz_from_R
from rigs.model import Rig
from scenes.base import Scene
from sim import mjcam
from sim.distortion import DistortionMap
from sim.errors import SimError
from sim.texture_cache import texture_store
from sim.vehicles import VehicleHandles, add_vehicle

ZNEAR_M = 0.05
ZFAR_M = 200.0
EXTENT_M = 20.0             # model "extent"; also scales shadow clip and fog
SHADOW_CLIP_M = 40.0        # half-size of the directional-light shadow frustum
SHADOW_SIZE = 1024         # shadow map texels (2048 costs ~1.5x more on llvmpipe)


def _set_visual(spec, rig: Rig, shadows: bool) -> None:
    """Speed-oriented rendering settings and absolute clip planes."""
    q = spec.visual.quality
    q.offsamples = 0
    q.shadowsize = SHADOW_SIZE if shadows else 0
    g = spec.visual.global_
    g.offwidth = max(int(g.offwidth), max(c.width for c in rig.cameras))
    g.offheight = max(int(g.offheight), max(c.height for c in rig.cameras))
    spec.stat.extent = EXTENT_M
    spec.visual.map.znear = ZNEAR_M / EXTENT_M
    spec.visual.map.zfar = ZFAR_M / EXTENT_M
    spec.visual.map.shadowclip = SHADOW_CLIP_M / EXTENT_M
    _limit_shadow_casters(spec, 1 if shadows else 0)


def _limit_shadow_casters(spec, n_max: int) -> None:
    """Keep ``castshadow`` on at most the ``n_max`` brightest (diffuse) casting lights.

    MuJoCo draws one shadow-map pass plus one extra lit scene pass per casting light per camera;
    on llvmpipe a second caster costs ~+60 % frame time for a barely visible second shadow.
    """
    casters = sorted((lt for lt in spec.lights if lt.castshadow),
                     key=lambda lt: -float(np.sum(lt.diffuse)))
    for lt in casters[n_max:]:
        lt.castshadow = False


def _no_reflections(spec) -> None:
    for mat in spec.materials:
        mat.reflectance = 0.0


class World:
    """A compiled MuJoCo world: ``model``, ``data`` and the vehicle's ids.

    ``camera_ids[k]`` / ``camera_names[k]`` belong to ``rig.cameras[k]``. ``render_rig`` is the
    rig MuJoCo renders: ``rig`` itself, except that a camera with lens distortion is replaced by
    the pinhole canvas of ``distortion_maps[k]`` (None for pinhole cameras).
    """

    def __init__(self, model, rig: Rig, handles: VehicleHandles, scene: Scene,
                 render_rig: Optional[Rig] = None, distortion_maps: tuple = ()):
        self.model = model
        self.data = mujoco.MjData(model)
        self.rig = rig
        self.render_rig = render_rig or rig
        self.distortion_maps = tuple(distortion_maps) or (None,) * len(rig.cameras)
        self.scene = scene
        self.handles = handles
        self.camera_names = handles.camera_names
        self.camera_ids = tuple(self._id(mujoco.mjtObj.mjOBJ_CAMERA, n) for n in handles.camera_names)
        self.body_id = self._id(mujoco.mjtObj.mjOBJ_BODY, handles.body)
        self.mocap_id = int(model.body_mocapid[self.body_id])
        self.imu_site_id = self._id(mujoco.mjtObj.mjOBJ_SITE, handles.imu_site)
        mujoco.mj_kinematics(model, self.data)
        mujoco.mj_camlight(model, self.data)

    def _id(self, objtype, name: str) -> int:
        i = mujoco.mj_name2id(self.model, objtype, name)
        if i < 0:
            raise SimError(f"world: no {objtype.name} named {name!r} in the compiled model")
        return int(i)

    def set_mocap_pose(self, body_name: str, T_w_x: np.ndarray) -> None:
        """Set the pose of mocap body ``body_name`` (no kinematics update)."""
        bid = self._id(mujoco.mjtObj.mjOBJ_BODY, body_name)
        mid = int(self.model.body_mocapid[bid])
        if mid < 0:
            raise SimError(f"world: body {body_name!r} is not a mocap body")
        self.data.mocap_pos[mid], self.data.mocap_quat[mid] = mjcam.pos_quat_from_T(T_w_x)

    def _set_mocap_poses(self, poses: dict) -> None:
        """Set many mocap bodies ``{name: T_w_x}`` at once (one batched rotation conversion: scenes with
        hundreds of actors pose them every frame)."""
        names = list(poses)
        batch = self.__dict__.get("_mocap_batch")
        if batch is None or batch[0] != names:             # the same bodies every frame: look them up once
            batch = self._mocap_batch = (names, np.array([self._mocap_index(n) for n in names]))
        mids = batch[1]
        T = np.asarray([poses[n] for n in names], dtype=float).reshape(-1, 4, 4)
        self.data.mocap_pos[mids] = T[:, :3, 3]
        self.data.mocap_quat[mids] = quat_wxyz_from_R(T[:, :3, :3])

    def _mocap_index(self, body_name: str) -> int:
        cache = self.__dict__.setdefault("_mocap_ids", {})
        if body_name not in cache:
            mid = int(self.model.body_mocapid[self._id(mujoco.mjtObj.mjOBJ_BODY, body_name)])
            if mid < 0:
                raise SimError(f"world: body {body_name!r} is not a mocap body")
            cache[body_name] = mid
        return cache[body_name]

    def set_vehicle_pose(self, T_w_b: np.ndarray, others: Optional[dict] = None) -> None:
        """Pose the vehicle (4,4 ``T_w_b``) and optional other mocap bodies ``{name: T_w_x}``,
        then update positions (``mj_kinematics``) and cameras/lights (``mj_camlight``); no step."""
        T_w_b = np.asarray(T_w_b, dtype=float)
        if T_w_b.shape != (4, 4) or not np.all(np.isfinite(T_w_b)):
            raise SimError(f"world.set_vehicle_pose: expected a finite (4,4) T_w_b, got shape {T_w_b.shape}")
        self.data.mocap_pos[self.mocap_id], self.data.mocap_quat[self.mocap_id] = \
            mjcam.pos_quat_from_T(T_w_b)
        if others:
            self._set_mocap_poses(others)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def T_w_c(self, k: int) -> np.ndarray:
        """(4,4) OpenCV pose of camera ``k`` as MuJoCo currently places it."""
        i = self.camera_ids[k]
        return mjcam.T_w_c_from_mj(self.data.cam_xpos[i], self.data.cam_xmat[i])


def _render_rig(rig: Rig, distort: bool, pool=None) -> tuple:
    """(render_rig, maps): distorted cameras replaced by their pinhole canvases (if ``distort``); ``pool``: an
    executor that makes the cameras' maps side by side (None: one after the other)."""
    if not distort:
        return rig, (None,) * len(rig.cameras)
    make = lambda c: DistortionMap(c) if c.has_distortion else None  # noqa: E731
    maps = tuple(pool.map(make, rig.cameras) if pool is not None else map(make, rig.cameras))
    cams = tuple(m.canvas_camera if m is not None else c for c, m in zip(rig.cameras, maps))
    return replace(rig, cameras=cams), maps


def build_world(scene: Scene, rig: Rig, vehicle: str = "cart",
                extra: Optional[Callable] = None, distort: bool = True, textures=None) -> World:
    """Compile ``scene`` + vehicle ``vehicle`` carrying ``rig``; ``extra(spec)`` may add more.

    With ``distort`` (default), cameras with lens distortion are rendered as pinhole canvases
    and :class:`sim.render.StereoRenderer` warps them to the exact distorted image; with
    ``distort=False`` every camera renders its pinhole ``K`` only (distortion ignored). ``textures``: the
    :class:`scenes.texture_store.TextureStore` the scene's textures come from (None: the machine's,
    :func:`sim.texture_cache.texture_store`).
    """
    spec = mujoco.MjSpec()
    spec.modelname = f"{getattr(scene, 'name', '') or 'scene'}_{rig.name}"
    with ThreadPoolExecutor(len(rig.cameras) + 1, thread_name_prefix="distortion-maps") as pool:
        maps_job = pool.submit(_render_rig, rig, distort, pool)   # numpy and OpenCV: beside the scene's build
        scene.add_to_spec(spec, textures=textures if textures is not None else texture_store())
        render_rig, maps = maps_job.result()
    handles = add_vehicle(spec, render_rig, kind=vehicle)
    if extra is not None:
        extra(spec)
    _set_visual(spec, render_rig, bool(scene.config.shadows))
    _no_reflections(spec)
    try:
        model = spec.compile()
    except Exception as e:  # mujoco raises ValueError with a multi-line message
        msg = " ".join(str(e).split())
        raise SimError(f"build_world: MuJoCo could not compile scene {scene.name!r}: {msg}") from None
    return World(model, rig, handles, scene, render_rig, maps)
