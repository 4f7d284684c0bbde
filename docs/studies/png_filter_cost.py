"""docs/simulator.md, Generation speed, PNG settings: encoding CPU ms and KB per image of a scenario's noisy (or, with
ideal=true, ideal) images, 10 frames spread over the route, for the row filters at level 1 with rle and huffman; the least
of 5 alternating rounds, one OpenCV thread; every setting checked lossless by decoding.
Usage: PYTHONPATH=. MUJOCO_GL=egl .venv/bin/python docs/studies/png_filter_cost.py SCENARIO [KEY=VALUE ...]"""
import sys
import time

import cv2
import numpy as np
from sim.generate import resolve
from sim.app.bench_generate import frames_config
from sim.rng import indexed_stream
from sim.sensors.camera import StereoCamera, add_noise
from sim.writers.common import PngOptions, encode_png
cv2.setNumThreads(1)
setup = resolve(frames_config(sys.argv[1], None, sys.argv[2:])); c = setup.config
picks = np.linspace(0, len(setup.frame_t_ns) - 1, 10).astype(int)
T = setup.trajectory.states(setup.frame_t_ns[picks]).T_w_b
imgs = []
with StereoCamera(setup.scene, setup.rig, vehicle=c.vehicle) as cam:
    for j, k in enumerate(picks):
        im, _, _ = cam.measure(T[j], setup.scene.actor_states(int(setup.frame_t_ns[k])))
        imgs += add_noise(im, setup.image_noise, indexed_stream(c.seed, "image_noise", int(k)))
settings = [PngOptions(1, "rle", f) for f in ("paeth", "avg", "sub", "up", "fast")] + [PngOptions(1, "huffman", f) for f in ("paeth", "avg", "sub")]
best = {s: 1e9 for s in settings}; size = {}
for r in range(5):
    for s in settings:
        c0 = time.process_time()
        out = [encode_png(im, png=s) for im in imgs]
        best[s] = min(best[s], 1e3 * (time.process_time() - c0) / len(imgs))
        size[s] = np.mean([len(b) for b in out]) / 1024
        if r == 0:
            assert all(np.array_equal(cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_UNCHANGED), im) for b, im in zip(out, imgs))
for s in settings:
    print(f"{s.strategy:8s} {s.filter:6s} {size[s]:7.1f} KB  {best[s]:5.2f} CPU ms/image (least of 5 rounds of {len(imgs)} images)")
