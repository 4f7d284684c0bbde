"""Cost of each sensor effect (docs/sensor_effects.md): CPU and wall ms per stereo frame of rendering plus effects,
campus-short frames 40-51, one StereoCamera.

Usage: MUJOCO_GL=egl .venv/bin/python docs/studies/effects_cost.py
"""
import time
import numpy as np
from sim.generate_config import CameraEffects
from sim.generate import resolve
from sim.scenarios import get_scenario
from sim.sensors.camera import FrameExposer, StereoCamera, add_noise
from sim.rng import indexed_stream

cfg = get_scenario("campus-short")
setup = resolve(cfg)
pose_at = lambda t: setup.trajectory.states(t).T_w_b
variants = {
    "default (no effects)": None,
    "blur 4 ms, 5 sub-frames": CameraEffects(exposure_ms=4.0),
    "blur 4 ms, 9 sub-frames": CameraEffects(exposure_ms=4.0, blur_subframes=9),
    "rolling shutter 30 us/row, 5 poses": CameraEffects(line_delay_us=30.0),
    "vignetting + auto exposure": CameraEffects(vignetting=0.5, auto_exposure=True),
    "shot + read noise": CameraEffects(read_noise_dn=1.2, shot_noise_gain=0.03),
    "realistic preset camera": __import__("sim.sensors.effects_presets", fromlist=["x"]).REALISTIC_CAMERA,
}
frames = range(40, 52)
with StereoCamera(setup.scene, setup.rig, vehicle=cfg.vehicle) as cam:
    cam.measure(pose_at(setup.frame_t_ns[:1])[0])          # warm-up
    for name, eff in variants.items():
        t0, w0 = time.process_time(), time.perf_counter()
        for k in frames:
            t = int(setup.frame_t_ns[k])
            if eff is None:
                imgs, _, _ = cam.measure(pose_at(np.array([t]))[0], setup.scene.actor_states(t))
                add_noise(imgs, 1.0, indexed_stream(0, "image_noise", k))
            else:
                ex = FrameExposer(cam, setup.rig, eff, 0.1, 0, 1.0)
                ex.expose(k, t, pose_at, setup.scene.actor_states)
        n = len(frames)
        print(f"{name:40s} cpu {1e3 * (time.process_time() - t0) / n:7.0f} ms/frame  wall {1e3 * (time.perf_counter() - w0) / n:7.0f} ms/frame", flush=True)
