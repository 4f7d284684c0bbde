"""Does rendered ground texture move with the geometry? (docs/studies/rop_consistency.md, "The common error").

Renders campus-short (cart27, ideal) frame pairs k, k+1 (k = 30, 33, .., 99) at the true poses with
``render.supersample`` S and measures the rendered frame k+1 against an exact geometric warp of frame
k over the ground corners (v > 330 px): sim.app.validation.render_fidelity.texture_motion.

Usage: .venv/bin/python docs/studies/render_fidelity_check.py [SUPERSAMPLE] [SCENARIO_SEED]   (defaults 1, 2)
"""
import sys
from dataclasses import replace

import numpy as np

from sim.generate import resolve
from sim.world import build_world
from sim.render import StereoRenderer
from sim.scenarios import get_scenario
from sim.app.validation.render_fidelity import texture_motion

np.set_printoptions(precision=4, suppress=True)
ss = int(sys.argv[1]) if len(sys.argv) > 1 else 1
seed = int(sys.argv[2]) if len(sys.argv) > 2 else 2
setup = resolve(replace(get_scenario("campus-short"), ideal=True, seed=seed))
T_w_b = setup.trajectory.states(setup.frame_t_ns).T_w_b
with StereoRenderer(build_world(setup.scene, setup.rig), depth=True, gray=True, supersample=ss) as r:
    E = texture_motion(r, [(T_w_b[k], T_w_b[k + 1]) for k in range(30, 100, 3)])
print(f"supersample {ss}, scenario seed {seed}: {len(E)} ground corners, rendered k+1 - exact warp of k: "
      f"mean (u, v) {E.mean(0)} px, standard error {E.std(0) / np.sqrt(len(E))}, std {E.std(0)}")
