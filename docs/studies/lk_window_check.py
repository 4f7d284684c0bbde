"""Translation LK vs affine refinement on a rendered textured ground plane (docs/studies/rop_consistency.md,
"KLT on perspective ground"). The cart27 rig drives 0.12 m along world y over the plain Lambertian
plane of tests/test_render_support.RenderTestScene, 10 frame pairs; corners of the lower image
(v > 300 px) are tracked forward (frame k -> k+1) and backward (k+1 -> k) by OpenCV's pyramidal LK
(tight termination: 100 iterations, 1e-4 px) at several window sizes, and refined by
vo.frontend.affine_lk.refine_affine (21 px); residuals against the exact projections (rendered depth
+ true poses). Usage: .venv/bin/python docs/studies/lk_window_check.py"""
import os
import sys

import cv2
import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, "tests")
from test_render_support import RenderTestScene, vehicle_pose  # noqa: E402

from rigs.presets import get_rig  # noqa: E402
from sim.world import build_world  # noqa: E402
from sim.render import StereoRenderer  # noqa: E402
from sim.app.validation.exact_points import exact_positions  # noqa: E402
from vo.frontend.affine_lk import refine_affine  # noqa: E402
from rigs.geometry import inv_T  # noqa: E402

rig = get_rig("cart27")
cam = rig.cameras[0]
yaw = np.pi / 2
d = np.array([np.cos(yaw), np.sin(yaw)])
world = build_world(RenderTestScene(wall_x=30.0, lit=True), rig)
pairs = []
with StereoRenderer(world, rig, depth=True) as r:
    for k in range(10):
        Tb0, Tb1 = vehicle_pose(*(0.37 * k * d), yaw), vehicle_pose(*((0.37 * k + 0.12) * d), yaw)
        pairs.append((Tb0, Tb1, r.render(Tb0), r.render(Tb1)))


def exact(p, f, Ta, Tb):
    """Exact positions in frame b of pixels p of frame a (depth of a, true poses)."""
    return exact_positions(cam, cam, p, f.depth[0].astype(np.float64), inv_T(Ta @ cam.T_b_c_array) @ (Tb @ cam.T_b_c_array))


def residuals(win, backward, affine):
    out = []
    for Ta, Tb, fa, fb in pairs:
        if backward:
            Ta, Tb, fa, fb = Tb, Ta, fb, fa
        g0, g1 = (cv2.cvtColor(f.images[0], cv2.COLOR_RGB2GRAY) for f in (fa, fb))
        p0 = cv2.goodFeaturesToTrack(g0, 1000, 0.01, 8, blockSize=3).reshape(-1, 2).astype(np.float64)
        pe, ok = exact(p0, fa, Ta, Tb)
        crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
        p1, st, _ = cv2.calcOpticalFlowPyrLK(g0, g1, p0.astype(np.float32).reshape(-1, 1, 2), None,
                                             winSize=(win, win), maxLevel=3, criteria=crit)
        p1 = p1.reshape(-1, 2).astype(np.float64)
        ok &= st.ravel() == 1
        if affine:
            p1, _, ok_a = refine_affine(g0, g1, p0, p1, win=21)
            ok &= ok_a
        res = p1 - pe
        m = ok & np.all(np.abs(res) < 1, axis=1) & (p0[:, 1] > 300)
        out.append(np.c_[res[m], p0[m], (pe - p0)[m]])
    return np.vstack(out)


print("tracker      dir  n      v resid (+-s.e.)   |flow v|  u resid left / right   std u, v")
for label, win, affine in (("LK 11", 11, False), ("LK 15", 15, False), ("LK 21", 21, False),
                           ("LK 31", 31, False), ("LK21+affine", 21, True)):
    for backward in (False, True):
        A = residuals(win, backward, affine)
        left, right = A[A[:, 2] < cam.width / 2], A[A[:, 2] >= cam.width / 2]
        print(f"{label:12s} {'bwd' if backward else 'fwd'}  {len(A):5d}  {A[:, 1].mean():+.4f} +- "
              f"{A[:, 1].std() / np.sqrt(len(A)):.4f}   {np.abs(A[:, 5]).mean():5.2f}     "
              f"{left[:, 0].mean():+.4f} / {right[:, 0].mean():+.4f}      "
              f"{A[:, 0].std():.3f}, {A[:, 1].std():.3f}", flush=True)
