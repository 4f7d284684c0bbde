"""Rendered image motion vs the exact geometric motion (docs/studies/rop_consistency.md): corners of left frame k are
tracked by pyramidal LK into (a) the rendered frame k+1 and (b) an exact warp of frame k to k+1 (rendered
depth of k+1, true poses, rig model); residuals against the exact projections, and a PnP fit of the
image motion to the exact 3-D points (the pose correction per step). Usage:
.venv/bin/python docs/studies/warp_check.py [N_SCENES]   (campus-short ideal with depth, seeds 1..N, cached)."""
import numpy as np, cv2, sys
from dataclasses import replace
from sim.scenarios import cached_dataset, get_scenario
from vo.dataset import open_dataset
from rigs.geometry import inv_T
from sim.app.validation.exact_points import backproject, local_depth
from sim.app.validation.render_fidelity import exact_warp
np.set_printoptions(precision=4, suppress=True, linewidth=200)
cfg = replace(get_scenario("campus-short"), ideal=True, depth=True)
res_real, res_syn, pos = [], [], []
CORR = {}
for s in range(int(sys.argv[1]) if len(sys.argv) > 1 else 2):
    ds = open_dataset(cached_dataset(replace(cfg, seed=cfg.seed + 1 + s), progress=False))
    gt = ds.groundtruth_cam0().T; cam = ds.rig.cameras[0]; K, D = cam.K, cam.dist_coeffs
    H, W = cam.height, cam.width
    for k in range(25, 100, 3):
        g0, g1 = ds.frame(k).left, ds.frame(k + 1).left
        T = inv_T(gt[k]) @ gt[k + 1]
        syn = exact_warp(g0, ds.depth(k + 1, 0), T, cam)     # synthetic frame k+1 from frame k
        p0 = cv2.goodFeaturesToTrack(g0, 600, 0.01, 8, blockSize=3).reshape(-1, 2).astype(np.float64)
        z, ok = local_depth(ds.depth(k, 0).astype(np.float64), p0)
        Tk = inv_T(gt[k + 1]) @ gt[k]
        P1 = backproject(cam, p0, z) @ Tk[:3, :3].T + Tk[:3, 3]
        pe, _ = cv2.projectPoints(P1, np.zeros(3), np.zeros(3), K, D); pe = pe.reshape(-1, 2)
        kw = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        a = p0.astype(np.float32).reshape(-1, 1, 2)
        pr, st1, _ = cv2.calcOpticalFlowPyrLK(g0, g1, a, None, **kw)
        ps, st2, _ = cv2.calcOpticalFlowPyrLK(g0, syn, a, None, **kw)
        m = ok & (st1.ravel() == 1) & (st2.ravel() == 1) & (pe[:, 0] > 15) & (pe[:, 0] < W - 15) & (pe[:, 1] > 15) & (pe[:, 1] < H - 15)
        for nm, pt in (("real", pr), ("syn", ps)):
            ptm = pt.reshape(-1, 2)[m]
            Pm = P1[m]
            rv, tv = np.zeros(3), np.zeros(3)
            okp, rv, tv, inl = cv2.solvePnPRansac(Pm, ptm, K, D, rvec=rv, tvec=tv, useExtrinsicGuess=True,
                                                  reprojectionError=0.5, iterationsCount=100, flags=cv2.SOLVEPNP_ITERATIVE)
            inl = inl.ravel()
            rv, tv = cv2.solvePnPRefineLM(Pm[inl], ptm[inl], K, D, rv, tv)
            CORR.setdefault(nm, []).append(np.r_[rv.ravel() * 1e3, tv.ravel() * 1e3, np.linalg.norm(T[:3, 3]) * 1e3])
        res_real.append((pr.reshape(-1, 2) - pe)[m]); res_syn.append((ps.reshape(-1, 2) - pe)[m]); pos.append(np.c_[pe[m], (pe - p0)[m]])
rr, rs, P = np.vstack(res_real), np.vstack(res_syn), np.vstack(pos)
def st(name, r, sel):
    r = r[sel]; g = np.all(np.abs(r) < 1, 1); r = r[g]
    print(f"{name:24s} n={len(r):5d} mean {r.mean(0)} median {np.median(r, 0)} std {r.std(0)} sem {r.std(0)/np.sqrt(len(r))}")
for name, sel in (("all", np.ones(len(P), bool)), ("bottom v>320", P[:, 1] > 320), ("top v<160", P[:, 1] < 160),
                  ("left u<240", P[:, 0] < 240), ("right u>480", P[:, 0] > 480), ("|flow|>5", np.linalg.norm(P[:, 2:], axis=1) > 5)):
    st("real  " + name, rr, sel); st("synth " + name, rs, sel)

for nm, c in CORR.items():
    c = np.array(c)
    print(nm, "PnP correction rot (mrad), trans (mm), step (mm): mean", c.mean(0), "sem", c.std(0) / np.sqrt(len(c)))
    print(nm, "  trans per step length (x1e3):", (c[:, 3:6] / c[:, 6:7]).mean(0) * 1e3)
