"""docs/simulator.md, World cache: CPU seconds of a scenario's world in one process, built (no cache) against taken
from the machine's world cache (a checkout: hard links and SHA-256 of the entry, then MuJoCo's binary model and the
parts loaded), the least of ROUNDS alternating rounds, after one warm-up of each (textures in the store, the entry
there); and the entry's size. Process CPU time (time.process_time), so robust to other load.
Usage: PYTHONPATH=. MUJOCO_GL=egl VO_TESTBED_CACHE=... .venv/bin/python docs/studies/world_cache_cost.py SCENARIO
[ROUNDS]"""
import sys
import time
from pathlib import Path

from sim.app.bench_generate import frames_config
from sim.generate import resolve
from sim.world import build_world
from sim.world_cache import world_cache, world_key

cfg = frames_config(sys.argv[1], None, ())
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
cache = world_cache()
best = {"build": 1e9, "cache": 1e9}
for r in range(rounds + 1):
    for mode in ("build", "cache"):
        setup = resolve(cfg)                               # a fresh, unbuilt scene each time
        c0 = time.process_time()
        if mode == "build":
            world = build_world(setup.scene, setup.rig, vehicle=cfg.vehicle)
        else:
            world, source = cache.world(cfg, setup.scene, setup.rig, cfg.vehicle)
        dt = time.process_time() - c0
        if r > 0:                                          # round 0: warm-up (and the miss that stores the entry)
            assert mode == "build" or source == "hit"
            best[mode] = min(best[mode], dt)
entry = cache.root / world_key(cfg, cfg.rig, cfg.vehicle)
mb = sum(p.stat().st_size for p in Path(entry).iterdir()) / 2 ** 20
print(f"{sys.argv[1]}: world built {best['build']:.3f} CPU s, from the cache {best['cache']:.3f} CPU s "
      f"(least of {rounds}); entry {mb:.1f} MB; ngeom {world.model.ngeom}")
