"""Ground truth vs rendered images over time (docs/studies/rop_consistency.md): corners of left frame k0 back-projected with
the rendered depth, moved by the true relative camera pose, projected into frame k1 (rig model, distortion) and
compared with where pyramidal LK finds them. Usage: .venv/bin/python docs/studies/truth_flow_check.py
(renders campus-short ideal with depth once, cached)."""
import numpy as np, cv2
from dataclasses import replace
from sim.scenarios import cached_dataset, get_scenario
from vo.dataset import open_dataset
from rigs.geometry import inv_T
np.set_printoptions(precision=3, suppress=True)
cfg = replace(get_scenario("campus-short"), ideal=True, depth=True)
ds = open_dataset(cached_dataset(cfg, progress=False))
gt = ds.groundtruth_cam0()
cam = ds.rig.cameras[0]
K = np.array([[cam.fx, 0, cam.cx], [0, cam.fy, cam.cy], [0, 0, 1.0]]); D = np.asarray(cam.distortion_coeffs if hasattr(cam,'distortion_coeffs') else cam.dist, float)
for k0, k1 in ((40, 41), (40, 44), (60, 64), (80, 84), (90, 91)):
    f0, f1 = ds.frame(k0), ds.frame(k1)
    g0 = f0.left if f0.left.ndim == 2 else cv2.cvtColor(f0.left, cv2.COLOR_RGB2GRAY)
    g1 = f1.left if f1.left.ndim == 2 else cv2.cvtColor(f1.left, cv2.COLOR_RGB2GRAY)
    p0 = cv2.goodFeaturesToTrack(g0, 800, 0.01, 8).reshape(-1, 2)
    p0 = cv2.cornerSubPix(g0, p0.astype(np.float32).reshape(-1,1,2), (5,5), (-1,-1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 40, 0.001)).reshape(-1,2)
    dep = ds.depth(k0, 0)
    # depth smoothness filter: skip discontinuities
    ij = np.round(p0).astype(int)
    win = np.array([dep[max(j-2,0):j+3, max(i-2,0):i+3] for i, j in ij], dtype=object)
    ok = np.array([np.ptp(w) < 0.02 * np.median(w) for w in win])
    z = np.array([dep[j, i] for i, j in ij])
    # bilinear depth at subpixel point
    xn = cv2.undistortPoints(p0.reshape(-1,1,2).astype(np.float64), K, D).reshape(-1,2)
    P0 = np.c_[xn, np.ones(len(xn))] * z[:, None]   # approx: depth at rounded pixel
    T = inv_T(gt.T[k1]) @ gt.T[k0]
    P1 = P0 @ T[:3,:3].T + T[:3,3]
    pred, _ = cv2.projectPoints(P1, np.zeros(3), np.zeros(3), K, D); pred = pred.reshape(-1,2)
    p1, st, _ = cv2.calcOpticalFlowPyrLK(g0, g1, p0.reshape(-1,1,2).astype(np.float32), pred.reshape(-1,1,2).astype(np.float32), winSize=(21,21), maxLevel=3, flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
    p1 = p1.reshape(-1,2); m = ok & (st.ravel()==1)
    r = p1[m] - pred[m]
    r = r[np.all(np.abs(r) < 2, axis=1)]
    print(k0, k1, "n", len(r), "mean resid (px)", np.mean(r, 0), "median", np.median(r, 0), "std", np.std(r, 0), "flow", np.median(np.linalg.norm(pred[m]-p0[m],axis=1)))
