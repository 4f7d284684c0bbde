"""Rendering throughput benchmark: stereo pairs per second along each scene's route.

``vo-testbed bench render [--scene NAME ...] [--shadows]`` prints one line per (scene, shadows) setting.
Poses: ``n_pairs`` points evenly spaced in arc length along ``scene.route.xy``, body on the
ground (``scene.ground_height``), yaw along the path; the default rig's cameras are 1.2 m high.
Only RGB rendering is timed (what dataset generation needs per frame), after 2 warm-up frames.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from rigs.geometry import make_T, rot_z
from rigs.model import Camera, Rig
from scenes.base import Scene, SceneConfig
from sim.errors import SimError
from sim.rng import scene_streams

R_B_C_FORWARD = np.array([[0.0, 0, 1], [-1, 0, 0], [0, -1, 0]])


@dataclass(frozen=True)
class BenchResult:
    scene: str
    width: int
    height: int
    pairs_per_s: float
    ms_per_pair: float
    shadows: bool
    cpu_ms_per_pair: float = float("nan")   # process CPU time (all threads): robust to other load
    build_s: float = float("nan")           # scene build + compile (textures, meshes), wall
    build_cpu_s: float = float("nan")       # the same in process CPU time
    texture_mb: float = float("nan")        # the compiled model's texture data


def default_bench_rig(width: int = 752, height: int = 480, baseline: float = 0.11,
                      height_m: float = 1.2) -> Rig:
    """EuRoC-sized stereo pinhole rig, cameras ``height_m`` above the ground, looking forward."""
    cams = tuple(Camera(f"cam{k}", width, height, 458.0, 457.0, (width - 1) / 2, (height - 1) / 2,
                        T_b_c=make_T(R_B_C_FORWARD, [0.1, y, height_m]))
                 for k, y in enumerate((baseline / 2, -baseline / 2)))
    return Rig("bench_stereo", cams)


def route_poses(scene: Scene, n: int) -> np.ndarray:
    """(n,4,4) ``T_w_b`` evenly spaced along the route polyline, yaw along the path."""
    xy = scene.route.xy
    if scene.route.closed:
        xy = np.vstack([xy, xy[:1]])
    seg = np.diff(xy, axis=0)
    s_cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(seg, axis=1))])
    s = np.linspace(0.0, s_cum[-1], n, endpoint=False)
    k = np.clip(np.searchsorted(s_cum, s, side="right") - 1, 0, len(seg) - 1)
    p = xy[k] + seg[k] * ((s - s_cum[k]) / np.linalg.norm(seg[k], axis=1))[:, None]
    yaw = np.arctan2(seg[k, 1], seg[k, 0])
    z = np.asarray(scene.ground_height(p[:, 0], p[:, 1]), dtype=float)
    return np.array([make_T(rot_z(a), [x, y, zz]) for a, (x, y), zz in zip(yaw, p, z)])


def _make_scene(name: str, shadows: bool) -> Scene:
    try:
        from scenes.registry import make_scene
    except ImportError as e:
        raise SimError(f"bench: scenes.registry.make_scene is not available yet ({e}); "
                       "pass Scene objects with scenes=...") from None
    config = SceneConfig(name=name, shadows=shadows)
    return make_scene(config, scene_streams(config.seed))


def bench_scene(scene: Scene, rig: Rig, n_pairs: int = 40) -> BenchResult:
    """Time ``n_pairs`` RGB stereo renders of ``scene`` along its route."""
    from sim.world import build_world
    from sim.render import StereoRenderer
    b0, bc0 = time.perf_counter(), time.process_time()
    world = build_world(scene, rig)
    build_s, build_cpu_s = time.perf_counter() - b0, time.process_time() - bc0
    poses = route_poses(scene, n_pairs)
    with StereoRenderer(world, rig) as r:
        for T in poses[:2]:
            r.render(T)
        t0, c0 = time.perf_counter(), time.process_time()
        for T in poses:
            r.render(T)
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
    cam = rig.cameras[0]
    return BenchResult(scene.name or type(scene).__name__, cam.width, cam.height,
                       n_pairs / dt, 1e3 * dt / n_pairs, bool(scene.config.shadows), 1e3 * dc / n_pairs,
                       build_s, build_cpu_s, world.model.tex_data.nbytes / 1e6)


def bench_render(scene_names=("campus", "indoor"), rig: Rig = None, n_pairs: int = 40,
                 shadows: bool = False, scenes=None) -> list:
    """Benchmark each named scene (via ``scenes.registry.make_scene``) or each given Scene."""
    rig = rig or default_bench_rig()
    todo = list(scenes) if scenes is not None else [_make_scene(n, shadows) for n in scene_names]
    out = []
    for sc in todo:
        if sc.config.shadows != shadows and scenes is None:
            sc.config = replace(sc.config, shadows=shadows)
        out.append(bench_scene(sc, rig, n_pairs))
    return out
