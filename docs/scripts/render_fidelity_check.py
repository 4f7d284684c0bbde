"""Does rendered ground texture move with the geometry? (docs/consistency.md, "The common error found").

Renders campus-short (cart27, ideal) frames k and k+1 at the true poses with ``render.supersample`` S, and an
exact geometric warp of frame k into frame k+1 (each pixel of k+1 back-projected with the rendered depth,
moved by the true relative pose, projected into k, sampled bicubically). Corners of the warp in the
lower image (ground, v > 330 px) are aligned to the rendered frame k+1 by the affine LK refinement
(vo.frontend.affine_lk, started at zero displacement): a renderer whose texture moves exactly with the
surface gives zero mean displacement.

Usage: .venv/bin/python docs/scripts/render_fidelity_check.py [SUPERSAMPLE] [SCENARIO_SEED]   (defaults 1, 2)
"""
import os
import sys
from dataclasses import replace

import cv2
import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
from sim.generate import resolve  # noqa: E402
from sim.model import build_world  # noqa: E402
from sim.render import StereoRenderer  # noqa: E402
from sim.scenarios import get_scenario  # noqa: E402
from vo.frontend.affine_lk import refine_affine  # noqa: E402
from vo.geometry import inv_T  # noqa: E402

np.set_printoptions(precision=4, suppress=True)
ss = int(sys.argv[1]) if len(sys.argv) > 1 else 1
seed = int(sys.argv[2]) if len(sys.argv) > 2 else 2
setup = resolve(replace(get_scenario("campus-short"), ideal=True, seed=seed))
T_w_b = setup.trajectory.states(setup.frame_t_ns).T_w_b
cam = setup.rig.cameras[0]
K, D, H, W = cam.K, cam.dist_coeffs, cam.height, cam.width
v, u = np.mgrid[0:H, 0:W].astype(np.float64)
xn = cv2.undistortPoints(np.c_[u.ravel(), v.ravel()].reshape(-1, 1, 2), K, D).reshape(-1, 2)
world = build_world(setup.scene, setup.rig)
disp = []
with StereoRenderer(world, depth=True, gray=True, supersample=ss) as r:
    for k in range(30, 100, 3):
        f0, f1 = r.render(T_w_b[k]), r.render(T_w_b[k + 1])
        X1 = np.c_[xn, np.ones(len(xn))] * f1.depth[0].astype(np.float64).ravel()[:, None]
        T_k_k1 = inv_T(T_w_b[k] @ cam.T_b_c_array) @ (T_w_b[k + 1] @ cam.T_b_c_array)
        with np.errstate(invalid="ignore"):
            X0 = X1 @ T_k_k1[:3, :3].T + T_k_k1[:3, 3]
        X0[~np.all(np.isfinite(X0), axis=1)] = 1e6          # sky: anything, it is masked below
        m = cv2.projectPoints(X0, np.zeros(3), np.zeros(3), K, D)[0].reshape(H, W, 2).astype(np.float32)
        warp = cv2.remap(f0.images[0], m[..., 0], m[..., 1], cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
        q = cv2.goodFeaturesToTrack(warp, 800, 0.01, 8, blockSize=3).reshape(-1, 2).astype(np.float64)
        q = q[(q[:, 1] > 330) & (q[:, 1] < H - 15) & (q[:, 0] > 15) & (q[:, 0] < W - 15)]
        q1, _, ok = refine_affine(warp, f1.images[0], q, q.copy())
        disp.append((q1 - q)[ok])
E = np.vstack(disp)
E = E[np.all(np.abs(E) < 1, axis=1)]
print(f"supersample {ss}, scenario seed {seed}: {len(E)} ground corners, rendered k+1 - exact warp of k: "
      f"mean (u, v) {E.mean(0)} px, standard error {E.std(0) / np.sqrt(len(E))}, std {E.std(0)}")
