"""What ``vo-testbed list`` shows: every built-in scene, rig, IMU model, scenario and estimator, with details.

Scenes and scenarios are resolved as ``generate`` resolves them (scene object, route, vehicle motion),
which needs no rendering, so the figures are those of the datasets they produce.
"""
from __future__ import annotations

import dataclasses

from rigs.imu_models import imu_model_names
from rigs.presets import get_rig, rig_names
from scenes.base import SceneConfig
from scenes.registry import make_scene, scene_names
from scenes.routes import polyline_length
from sim.generate import resolve
from sim.rng import scene_streams
from sim.scenarios import get_scenario, scenario_names
from vo.estimators.registry import describe, estimator_names

PLUGINS = {
    "scene": "--scene package.module:SceneClass (a scenes.base.Scene subclass; see docs/extending.md)",
    "rig": "--rig path/to/rig.yaml (the format of rigs/presets/*.yaml; see docs/extending.md)",
    "estimator": "--estimator package.module:Class (a vo.estimators.base.Estimator subclass) or "
                 "'cmd:<program {dataset} {out}>'",
}


def scene_details(name: str) -> dict:
    """Route length (m), closed or not, GCP names, cruise speed."""
    scene = make_scene(SceneConfig(name=name, seed=0), scene_streams(0))
    route = scene.route
    length = scene.route_length() if hasattr(scene, "route_length") else polyline_length(route.xy, route.closed)
    return {"route_length_m": round(float(length), 2), "closed": bool(route.closed),
            "cruise_speed_mps": float(route.cruise_speed_mps), "gcps": [g.name for g in scene.gcp_sites]}


def scene_knobs() -> dict:
    """``scene.<field>`` -> {"default", "doc"} for every scene knob (SceneConfig fields but name/seed)."""
    return {f"scene.{f.name}": {"default": f.default, "doc": f.metadata.get("doc", "")}
            for f in dataclasses.fields(SceneConfig) if f.name not in ("name", "seed")}


def rig_details(name: str) -> dict:
    rig = get_rig(name)
    cam = rig.cameras[0]
    return {"resolution": [int(cam.width), int(cam.height)], "baseline_m": round(float(rig.baseline), 4),
            "camera_rate_hz": float(rig.camera_rate_hz),
            "imu_rate_hz": float(rig.imu.rate_hz) if rig.imu is not None else None,
            "imu": rig.imu.name if rig.imu is not None else None, "mount": rig.mount, "lens": cam.dist_model}


def scenario_details(name: str) -> dict:
    config = get_scenario(name)
    setup = resolve(config)
    t = setup.frame_t_ns
    return {"scene": config.scene.name, "rig": config.rig.name, "seed": int(config.seed),
            "duration_s": round(float((t[-1] - t[0]) * 1e-9), 2), "frames": int(len(t)),
            "path_length_m": round(float(setup.trajectory.path_length()), 2)}


def estimator_details(name: str) -> str:
    return describe(name)


def catalogue(details: bool = True) -> dict:
    """Everything ``list`` prints; with ``details=False`` only the names (fast)."""
    if not details:
        return {"scenes": list(scene_names()), "rigs": list(rig_names()), "imu_models": list(imu_model_names()),
                "scenarios": list(scenario_names()), "estimators": list(estimator_names()), "plugins": PLUGINS}
    return {"scenes": {n: scene_details(n) for n in scene_names()}, "scene_knobs": scene_knobs(),
            "rigs": {n: rig_details(n) for n in rig_names()}, "imu_models": list(imu_model_names()),
            "scenarios": {n: scenario_details(n) for n in scenario_names()},
            "estimators": {n: estimator_details(n) for n in estimator_names()}, "plugins": PLUGINS}


def catalogue_text(cat: dict) -> str:
    """Plain-text rendering of :func:`catalogue` (details)."""
    lines = ["scenes:"]
    for n, d in cat["scenes"].items():
        lines.append(f"  {n:<16} route {d['route_length_m']:.1f} m ({'loop' if d['closed'] else 'open'}, "
                     f"{d['cruise_speed_mps']:g} m/s), GCPs: {', '.join(d['gcps']) or 'none'}")
    lines.append("  knobs (--set KEY=VALUE): " + ", ".join(f"{k}={v['default']}" for k, v in cat["scene_knobs"].items()))
    lines.append("rigs:")
    for n, d in cat["rigs"].items():
        imu = f", IMU {d['imu']} {d['imu_rate_hz']:g} Hz" if d["imu"] else ", no IMU"
        lines.append(f"  {n:<16} {d['resolution'][0]}x{d['resolution'][1]}, baseline {d['baseline_m']:g} m, "
                     f"camera {d['camera_rate_hz']:g} Hz{imu}"
                     + (f", {d['lens']} (fisheye) lens" if d.get("lens") == "equidistant" else ""))
    lines.append("imu models: " + ", ".join(cat["imu_models"]))
    lines.append("scenarios:")
    for n, d in cat["scenarios"].items():
        lines.append(f"  {n:<16} scene {d['scene']}, rig {d['rig']}, {d['duration_s']:g} s, {d['frames']} frames, "
                     f"{d['path_length_m']:g} m")
    lines.append("estimators:")
    for n, doc in cat["estimators"].items():
        lines.append(f"  {n:<16} {doc}")
    lines.append("plug-ins (no edit of the package needed):")
    lines += [f"  {k:<16} {v}" for k, v in cat["plugins"].items()]
    return "\n".join(lines)
