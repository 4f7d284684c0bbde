"""docs/studies/rop_consistency.md. Render campus-short frame pairs at truth poses under spec variants; PnP-fit the image
motion to exact depth points; LK residuals per rendered object.
Usage: .venv/bin/python docs/studies/render_variant_check.py base|nolight|nohead|nospec [RIG]"""
import os, sys; os.environ.setdefault("MUJOCO_GL", "egl")
import numpy as np, cv2, mujoco
from dataclasses import replace
from sim.app.validation.exact_points import backproject, local_depth
from sim.scenarios import get_scenario
from sim.generate import resolve
from sim.world import build_world
from sim.render import StereoRenderer
from rigs.geometry import inv_T
np.set_printoptions(precision=4, suppress=True, linewidth=200)
variant = sys.argv[1]; rigname = sys.argv[2] if len(sys.argv) > 2 else "stereo27"

def extra(spec):
    if "nolight" in variant:
        spec.visual.headlight.diffuse = [0, 0, 0]; spec.visual.headlight.specular = [0, 0, 0]
        for lt in spec.lights: lt.specular = [0, 0, 0]
        for m in spec.materials: m.specular = 0.0; m.shininess = 0.0
    if "nohead" in variant:
        spec.visual.headlight.diffuse = [0, 0, 0]
    if "nospec" in variant:
        for lt in spec.lights: lt.specular = [0, 0, 0]
        for m in spec.materials: m.specular = 0.0; m.shininess = 0.0

cfg = replace(get_scenario("campus-short"), ideal=True, seed=1, rig=rigname)
s = resolve(cfg)
T_w_b = s.trajectory.states(s.frame_t_ns).T_w_b
world = build_world(s.scene, s.rig, extra=extra)
cam = s.rig.cameras[0]; K, D = cam.K, cam.dist_coeffs; H, W = cam.height, cam.width
C = {"all": [], "bottom": []}; RES = []; SEG = {}
with StereoRenderer(world, s.rig, depth=True, segmentation=True) as r:
    for k in range(30, 100, 2):
        f0, f1 = r.render(T_w_b[k]), r.render(T_w_b[k + 1])
        g0, g1 = [cv2.cvtColor(f.images[0], cv2.COLOR_RGB2GRAY) if f.images[0].ndim == 3 else f.images[0] for f in (f0, f1)]
        T0, T1 = T_w_b[k] @ cam.T_b_c_array, T_w_b[k + 1] @ cam.T_b_c_array
        p0 = cv2.goodFeaturesToTrack(g0, 800, 0.01, 8, blockSize=3).reshape(-1, 2).astype(np.float64)
        z, ok = local_depth(f0.depth[0].astype(np.float64), p0)
        Tk = inv_T(T1) @ T0
        P1 = backproject(cam, p0, z) @ Tk[:3, :3].T + Tk[:3, 3]
        kw = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        pr, st, _ = cv2.calcOpticalFlowPyrLK(g0, g1, p0.astype(np.float32).reshape(-1, 1, 2), None, **kw)
        pr = pr.reshape(-1, 2)
        for nm, sel in (("all", ok), ("bottom", ok & (p0[:, 1] > 300))):
            m = sel & (st.ravel() == 1)
            if m.sum() < 20: continue
            okp, rv, tv, inl = cv2.solvePnPRansac(P1[m], pr[m], K, D, rvec=np.zeros(3), tvec=np.zeros(3), useExtrinsicGuess=True,
                                                  reprojectionError=0.5, iterationsCount=100, flags=cv2.SOLVEPNP_ITERATIVE)
            inl = inl.ravel(); rv, tv = cv2.solvePnPRefineLM(P1[m][inl], pr[m][inl], K, D, rv, tv)
            C[nm].append(np.r_[rv.ravel() * 1e3, tv.ravel() * 1e3, np.linalg.norm(Tk[:3, 3]) * 1e3])
        pe, _ = cv2.projectPoints(P1, np.zeros(3), np.zeros(3), K, D); res = pr - pe.reshape(-1, 2)
        m = ok & (st.ravel() == 1) & np.all(np.abs(res) < 1, 1) & (p0[:, 1] > 320)
        RES.append(res[m])
        ij = np.round(p0).astype(int); gid = f0.seg[0][ij[:, 1], ij[:, 0], 0]
        m2 = ok & (st.ravel() == 1) & np.all(np.abs(res) < 1, 1)
        for g in np.unique(gid[m2]):
            SEG.setdefault(int(g), []).append(np.c_[res[m2 & (gid == g)], p0[m2 & (gid == g)]])
for nm, c in C.items():
    c = np.array(c); c = c[np.all(np.abs(c[:, :3]) < 5, 1)]
    print(variant, rigname, nm, "rot mrad/step", c[:, :3].mean(0), "trans/path (1e-3)", c[:, 3:6].sum(0) / c[:, 6].sum() * 1e3, "+-", c[:, 3:6].std(0) * np.sqrt(len(c)) / c[:, 6].sum() * 1e3)
R = np.vstack(RES); print(variant, "LK resid bottom v>320: mean", R.mean(0), "median", np.median(R, 0), "sem", R.std(0) / np.sqrt(len(R)))

for g, L in sorted(SEG.items(), key=lambda kv: -sum(len(x) for x in kv[1]))[:10]:
    A = np.vstack(L); nm = mujoco.mj_id2name(world.model, mujoco.mjtObj.mjOBJ_GEOM, g) if g >= 0 else "none"
    print(f"{nm:30s} n={len(A):5d} resid mean {A[:, :2].mean(0)} sem {A[:, :2].std(0) / np.sqrt(len(A))} mean pos {A[:, 2:].mean(0)}")
