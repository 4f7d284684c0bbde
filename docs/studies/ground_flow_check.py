"""Plain textured ground plane (tests/test_render_support.RenderTestScene, Lambertian, no headlight): LK
residuals of ground corners between two rendered frames against the exact motion, optionally
supersampled. Usage: .venv/bin/python docs/studies/ground_flow_check.py RIG YAW SUPERSAMPLE
(e.g. cart27 1.5708 1|2|3: the cart drives along world y; docs/studies/rop_consistency.md)."""
import os, sys; sys.path.insert(0, "tests"); os.environ.setdefault("MUJOCO_GL", "egl")
import numpy as np, cv2
from test_render_support import RenderTestScene, vehicle_pose
from sim.app.validation.exact_points import exact_positions
from sim.world import build_world
from sim.render import StereoRenderer
from rigs.presets import get_rig
from rigs.geometry import inv_T
np.set_printoptions(precision=4, suppress=True, linewidth=200)
rig = get_rig(sys.argv[1] if len(sys.argv) > 1 else "cart27")
SS = int(sys.argv[3]) if len(sys.argv) > 3 else 1
from dataclasses import replace as _rep
rig_r = _rep(rig, cameras=tuple(_rep(c, width=c.width * SS, height=c.height * SS, fx=c.fx * SS, fy=c.fy * SS,
                                      cx=c.cx * SS + (SS - 1) / 2, cy=c.cy * SS + (SS - 1) / 2) for c in rig.cameras))
yaw = float(sys.argv[2]) if len(sys.argv) > 2 else 0.0
world = build_world(RenderTestScene(wall_x=30.0, lit=True), rig_r)
cam = rig.cameras[0]
R = []
d = np.array([np.cos(yaw), np.sin(yaw)])
with StereoRenderer(world, rig_r, depth=True) as r:
    for k in range(12):
        x0 = 0.37 * k
        Tb0, Tb1 = vehicle_pose(*(x0 * d), yaw), vehicle_pose(*((x0 + 0.12) * d), yaw)
        f0, f1 = r.render(Tb0), r.render(Tb1)
        g0, g1 = [cv2.resize(cv2.cvtColor(f.images[0], cv2.COLOR_RGB2GRAY), (cam.width, cam.height), interpolation=cv2.INTER_AREA) for f in (f0, f1)]
        p0 = cv2.goodFeaturesToTrack(g0, 1000, 0.01, 8, blockSize=3).reshape(-1, 2).astype(np.float64)
        dep = f0.depth[0].astype(np.float64)
        if SS > 1:
            dep = 1.0 / cv2.resize(1.0 / dep, (cam.width, cam.height), interpolation=cv2.INTER_AREA)
        pe, ok = exact_positions(cam, cam, p0, dep, inv_T(Tb0 @ cam.T_b_c_array) @ (Tb1 @ cam.T_b_c_array))
        kw = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        pr, st, _ = cv2.calcOpticalFlowPyrLK(g0, g1, p0.astype(np.float32).reshape(-1, 1, 2), None, **kw)
        res = pr.reshape(-1, 2) - pe
        m = ok & (st.ravel() == 1) & np.all(np.abs(res) < 1, 1) & (p0[:, 1] > 300)
        R.append(np.c_[res[m], p0[m], pe[m] - p0[m]])
A = np.vstack(R)
for nm, sel in (("bottom", np.ones(len(A), bool)), ("bottom-left", A[:, 2] < 360), ("bottom-right", A[:, 2] >= 360)):
    B = A[sel]; print(rig.name, "SS", SS, "yaw", yaw, nm, "n", len(B), "resid mean", B[:, :2].mean(0), "median", np.median(B[:, :2], 0), "sem", B[:, :2].std(0) / np.sqrt(len(B)), "flow", B[:, 4:].mean(0))
