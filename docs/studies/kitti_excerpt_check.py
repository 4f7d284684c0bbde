"""Is a real KITTI-layout recording consistent with its ground truth and calibration? Checked from the images.

Independent of the estimators' pipelines (only OpenCV's LK / ORB and the rig's calibration):

* **Scale per step.** For each consecutive pair k, k+1: Shi-Tomasi corners of left image k, matched into
  the right image k by LK (forward-backward 1 px, no epipolar gate), triangulated with the calibration's
  baseline (depth 2-40 m), tracked into left image k+1 by LK (forward-backward 1 px); PnP RANSAC (2 px)
  then LM on the inliers gives the step the stereo depth implies. Its length over the true step's length
  is the scale the calibration and the images give against the poses; a wrong baseline (another KITTI
  calibration) or poses of another rate would show as a constant ratio away from 1.
* **Rotation per step**: the PnP step's rotation angle against the true one (deg).
* **Rectification**: vertical disparity ``v_right - v_left`` of the left-right matches (median, robust std
  1.4826 MAD, share beyond 1 px), and the same for ORB descriptor matches (no window bias).
* **Times**: the frame interval and the speed the poses give with it.
* **Disparity offset**: the step-length ratio in three depth bands (disparity > 25, 15-25, < 15 px) with the
  depths ``f b / (d + delta)`` for a few offsets ``delta``: a wrong baseline or poses of the wrong scale give
  one ratio in every band; a disparity offset (the right camera's ``cx`` of the images differing from the
  calibration's) gives a ratio growing with depth that one ``delta`` flattens.
* **Road plane**: the left camera's height above the road from SGBM stereo (bottom-centre window, RANSAC plane)
  against the KITTI rig's 1.65 m, every 5th frame.
* **Stereo at large disparities**: left-right LK success (forward-backward) and LK minus SGBM disparity per
  disparity band.
* **Flow**: magnitude of the frame-to-frame flow the true motion and stereo depth predict for the corners
  (median / 95th percentile / max px per step), and its share beyond the LK pyramid's reach
  ``(win // 2) * (2 ** levels - 1)`` px.

Usage::

    python docs/studies/kitti_excerpt_check.py ../shared/data/real/kitti_turn [--csv steps.csv]
"""
from __future__ import annotations

import argparse

import cv2
import numpy as np

from rigs.geometry import inv_T, make_T, rotation_angle
from vo.dataset import open_dataset

FB_PX = 1.0
WIN, LEVELS = 21, 4          # seed 003's LK window and pyramid levels (KltConfig defaults)


def lk_fb(img0, img1, p0, win=WIN, max_level=LEVELS - 1):
    """LK img0 -> img1 with a 1 px forward-backward check -> (p1 (N,2), ok (N,))."""
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)
    a = p0.astype(np.float32).reshape(-1, 1, 2)
    p1, st, _ = cv2.calcOpticalFlowPyrLK(img0, img1, a, None, winSize=(win, win), maxLevel=max_level, criteria=crit)
    pb, stb, _ = cv2.calcOpticalFlowPyrLK(img1, img0, p1, None, winSize=(win, win), maxLevel=max_level, criteria=crit)
    ok = st.ravel().astype(bool) & stb.ravel().astype(bool)
    ok &= np.linalg.norm(pb.reshape(-1, 2) - p0, axis=1) < FB_PX
    return p1.reshape(-1, 2).astype(np.float64), ok


def orb_vertical(left, right, n=2000):
    """Vertical disparity (N,) of cross-checked ORB matches with 0 < disparity < 200 px."""
    orb = cv2.ORB_create(n)
    k0, d0 = orb.detectAndCompute(left, None)
    k1, d1 = orb.detectAndCompute(right, None)
    m = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(d0, d1)
    p0 = np.array([k0[x.queryIdx].pt for x in m])
    p1 = np.array([k1[x.trainIdx].pt for x in m])
    d = p0[:, 0] - p1[:, 0]
    keep = (d > 0) & (d < 200) & (np.abs(p1[:, 1] - p0[:, 1]) < 10)
    return (p1[:, 1] - p0[:, 1])[keep]


def offsets(ds, fx, cx, cy, b, K, T, deltas=(0.0, 0.5, 1.0, 1.4, 2.0)):
    """Median PnP step / true step per depth band for each disparity offset (see the module docstring)."""
    data, prev = [], None
    for k in range(len(ds)):
        fr = ds.frame(k)
        if prev is not None:
            l0, r0 = prev
            c = cv2.goodFeaturesToTrack(l0, 1500, 0.01, 10).reshape(-1, 2).astype(np.float64)
            pr, okr = lk_fb(l0, r0, c)
            d = c[:, 0] - pr[:, 0]
            okr &= (np.abs(pr[:, 1] - c[:, 1]) < 1) & (d > fx * b / 40) & (d < fx * b / 2)
            p1, okt = lk_fb(l0, fr.left, c)
            ok = okr & okt
            data.append((c[ok], d[ok], p1[ok], inv_T(T[k - 1]) @ T[k]))
        prev = (fr.left, fr.right)
    bands = (("d>25", 25, 1e9), ("15-25", 15, 25), ("d<15", 0, 15))
    for delta in deltas:
        out = []
        for name, lo, hi in bands:
            rs = []
            for c, d, p1, T_true in data:
                sel = (d > lo) & (d <= hi)
                if sel.sum() < 8:
                    continue
                z = fx * b / (d[sel] + delta)
                p3 = np.c_[(c[sel, 0] - cx) * z / fx, (c[sel, 1] - cy) * z / fx, z]
                ret, rvec, tvec, inl = cv2.solvePnPRansac(p3, p1[sel], K, None, reprojectionError=2.0,
                                                           iterationsCount=300)
                if not ret or inl is None or len(inl) < 8:
                    continue
                rvec, tvec = cv2.solvePnPRefineLM(p3[inl.ravel()], p1[sel][inl.ravel()], K, None, rvec, tvec)
                T_est = inv_T(make_T(cv2.Rodrigues(rvec)[0], tvec.ravel()))
                rs.append(np.linalg.norm(T_est[:3, 3]) / np.linalg.norm(T_true[:3, 3]))
            out.append(f"{name} {np.median(rs):.3f} (n {len(rs)})")
        print(f"disparity offset {delta:+.1f} px: step ratio " + "  ".join(out))


def road_and_stereo(ds, fx, cx, cy, b):
    """Camera height above the road (SGBM, RANSAC plane) and LK stereo against SGBM by disparity band."""
    sg = cv2.StereoSGBM_create(minDisparity=0, numDisparities=128, blockSize=5, P1=8 * 25, P2=32 * 25,
                               uniquenessRatio=10, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)
    rng = np.random.default_rng(0)
    heights, diffs, dsg, lk_ok = [], [], [], []
    for k in range(0, len(ds), 5):
        fr = ds.frame(k)
        D = sg.compute(fr.left, fr.right).astype(np.float32) / 16.0
        h, w = D.shape
        v, u = np.mgrid[0:h, 0:w]
        m = (v > h * 0.75) & (u > w * 0.36) & (u < w * 0.64) & (D > 5)
        z = fx * b / D[m]
        P = np.c_[(u[m] - cx) * z / fx, (v[m] - cy) * z / fx, z][::10]
        best = None
        for _ in range(300):
            s3 = P[rng.choice(len(P), 3, replace=False)]
            n = np.cross(s3[1] - s3[0], s3[2] - s3[0])
            if np.linalg.norm(n) < 1e-9:
                continue
            n /= np.linalg.norm(n)
            inl = np.abs((P - s3[0]) @ n) < 0.03
            if best is None or inl.sum() > best.sum():
                best = inl
        Q = P[best]
        n = np.linalg.svd(Q - Q.mean(0))[2][2]
        heights.append(abs(n @ Q.mean(0)))
        c = cv2.goodFeaturesToTrack(fr.left, 1500, 0.01, 10).reshape(-1, 2).astype(np.float64)
        d_sg = D[c[:, 1].astype(int), c[:, 0].astype(int)]
        pr, ok = lk_fb(fr.left, fr.right, c)
        valid = d_sg > 1
        dsg.append(d_sg[valid])
        lk_ok.append(ok[valid])
        diffs.append(np.where(ok[valid], c[valid, 0] - pr[valid, 0] - d_sg[valid], np.nan))
    print(f"camera height above the road (SGBM stereo, {len(heights)} frames): median {np.median(heights):.3f} m, "
          f"range {min(heights):.3f}-{max(heights):.3f} m (KITTI rig: 1.65 m)")
    dsg, lk_ok, diffs = np.concatenate(dsg), np.concatenate(lk_ok), np.concatenate(diffs)
    for lo, hi in ((1, 10), (10, 20), (20, 40), (40, 80), (80, 128)):
        sel = (dsg >= lo) & (dsg < hi)
        dd = diffs[sel & lk_ok]
        print(f"stereo, SGBM disparity {lo:3d}-{hi:3d} px: {sel.sum():5d} corners, LK fb success {lk_ok[sel].mean():.3f}, "
              f"LK - SGBM median {np.median(dd) if len(dd) else np.nan:+.3f} px, |diff| > 1 px "
              f"{np.mean(np.abs(dd) > 1) if len(dd) else np.nan:.3f}")


def robust_std(x):
    return 1.4826 * np.median(np.abs(x - np.median(x))) if len(x) else np.nan


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--csv", help="write the per-step table here")
    args = ap.parse_args(argv)
    ds = open_dataset(args.dataset)
    cam0, cam1 = ds.rig.cameras[0], ds.rig.cameras[1]
    K = cam0.K
    fx, cx, cy = K[0, 0], K[0, 2], K[1, 2]
    b = float(np.linalg.norm(ds.rig.T_c0_c1[:3, 3]))
    gt = ds.groundtruth_cam0()
    T = gt.T
    dt = np.diff(ds.frame_times_ns) * 1e-9
    reach = (WIN // 2) * (2 ** LEVELS - 1)
    print(f"{ds.path}: {len(ds)} frames {cam0.width}x{cam0.height}, fx {fx:.3f}, cx {cx:.3f}, cy {cy:.3f}, "
          f"baseline {b:.5f} m (P1 -fx*b {-fx * b:.4f}); right K equal: {np.allclose(cam0.K, cam1.K)}")
    print(f"frame interval {np.median(dt):.4f} s (min {dt.min():.4f}, max {dt.max():.4f}); "
          f"true step {np.median(np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)):.3f} m median; "
          f"LK reach {reach} px (win {WIN}, {LEVELS} levels)")
    rows, vd_klt, vd_orb = [], [], []
    prev = None
    for k in range(len(ds)):
        fr = ds.frame(k)
        left = fr.left if fr.left.ndim == 2 else cv2.cvtColor(fr.left, cv2.COLOR_BGR2GRAY)
        right = fr.right if fr.right.ndim == 2 else cv2.cvtColor(fr.right, cv2.COLOR_BGR2GRAY)
        vd_orb.append(orb_vertical(left, right))
        if prev is not None:
            l0, r0 = prev
            c = cv2.goodFeaturesToTrack(l0, 1500, 0.01, 10).reshape(-1, 2).astype(np.float64)
            pr, okr = lk_fb(l0, r0, c)
            disp = c[:, 0] - pr[:, 0]
            vd = pr[:, 1] - c[:, 1]
            vd_klt.append(vd[okr & (disp > 0.5)])
            okr &= (disp > fx * b / 40.0) & (disp < fx * b / 2.0) & (np.abs(vd) < 1.0)
            z = fx * b / np.where(okr, disp, 1.0)
            p3 = np.c_[(c[:, 0] - cx) * z / fx, (c[:, 1] - cy) * z / fx, z]
            p1, okt = lk_fb(l0, left, c)
            ok = okr & okt
            T_true = inv_T(T[k - 1]) @ T[k]          # T_{c(k-1)}_{c(k)}
            # predicted flow of every stereo point under the true motion
            q = (inv_T(T_true)[:3, :3] @ p3[okr].T).T + inv_T(T_true)[:3, 3]
            flow_pred = np.linalg.norm(q[:, :2] / q[:, 2:3] * fx + [cx, cy] - c[okr], axis=1)
            ret, rvec, tvec, inl = cv2.solvePnPRansac(p3[ok], p1[ok], K, None, reprojectionError=2.0,
                                                       iterationsCount=500, flags=cv2.SOLVEPNP_ITERATIVE)
            if ret and inl is not None and len(inl) >= 10:
                idx = inl.ravel()
                rvec, tvec = cv2.solvePnPRefineLM(p3[ok][idx], p1[ok][idx], K, None, rvec, tvec)
                T_est = inv_T(make_T(cv2.Rodrigues(rvec)[0], tvec.ravel()))
                t_true = np.linalg.norm(T_true[:3, 3])
                rows.append((k, t_true, np.linalg.norm(T_est[:3, 3]) / t_true,
                             np.degrees(rotation_angle(T_true[:3, :3])),
                             np.degrees(rotation_angle(T_est[:3, :3].T @ T_true[:3, :3])),
                             len(idx), int(ok.sum()), np.median(flow_pred), np.percentile(flow_pred, 95),
                             flow_pred.max(), float(np.mean(flow_pred > reach)), float(np.median(disp[ok])),
                             np.degrees(rotation_angle(T_est[:3, :3]))))
        prev = (left, right)
    a = np.array(rows)
    hdr = "step  true_m  scale  rot_deg  rot_err_deg  inliers  points  flow_med  flow_p95  flow_max  beyond_reach  disp_med"
    print(hdr)
    for r in a:
        print(f"{int(r[0]):4d} {r[1]:7.3f} {r[2]:6.3f} {r[3]:8.2f} {r[4]:11.3f} {int(r[5]):8d} {int(r[6]):7d} "
              f"{r[7]:9.1f} {r[8]:9.1f} {r[9]:9.1f} {r[10]:12.3f} {r[11]:9.1f}")
    s = a[:, 2]
    w = a[:, 1]
    print(f"scale (PnP step / true step): median {np.median(s):.4f}, mean {s.mean():.4f}, "
          f"robust std {robust_std(s):.4f}, path-weighted {np.sum(s * w) / w.sum():.4f}; "
          f"first half {np.median(s[: len(s) // 2]):.4f}, second half {np.median(s[len(s) // 2:]):.4f}")
    print(f"rotation error per step: median {np.median(a[:, 4]):.4f} deg, max {a[:, 4].max():.4f} deg; "
          f"summed rotation angle: images {a[:, 12].sum():.2f} deg, poses {a[:, 3].sum():.2f} deg "
          f"(ratio {a[:, 12].sum() / a[:, 3].sum():.4f}); summed step length ratio {np.sum(a[:, 2] * a[:, 1]) / a[:, 1].sum():.4f}")
    # time offset: shift (frames) of the poses' rotation-rate profile that best fits the images' (linear interp.)
    kk = a[:, 0]
    shifts = np.arange(-3.0, 3.01, 0.1)
    cost = [np.mean((a[:, 12] - np.interp(kk + sh, kk, a[:, 3])) ** 2) for sh in shifts]
    best = shifts[int(np.argmin(cost))]
    print(f"rotation-rate profile: images vs poses rms {np.sqrt(cost[30]):.3f} deg/step at shift 0, "
          f"best shift {best:+.1f} frames (rms {np.sqrt(min(cost)):.3f} deg/step)")
    v1, v2 = np.concatenate(vd_klt), np.concatenate(vd_orb)
    print(f"vertical disparity, LK matches ({len(v1)}): median {np.median(v1):+.3f} px, robust std "
          f"{robust_std(v1):.3f} px, |dv| > 1 px {np.mean(np.abs(v1) > 1):.3f}")
    print(f"vertical disparity, ORB matches ({len(v2)}): median {np.median(v2):+.3f} px, robust std "
          f"{robust_std(v2):.3f} px, |dv| > 1 px {np.mean(np.abs(v2) > 1):.3f}")
    print(f"predicted flow: median of step medians {np.median(a[:, 7]):.1f} px, max p95 {a[:, 8].max():.1f} px, "
          f"max {a[:, 9].max():.1f} px; share beyond reach {reach} px: mean {a[:, 10].mean():.4f}, max {a[:, 10].max():.4f}")
    offsets(ds, fx, cx, cy, b, K, T)
    road_and_stereo(ds, fx, cx, cy, b)
    if args.csv:
        np.savetxt(args.csv, a, delimiter=",", header=hdr.replace("  ", ","), fmt="%.5f")


if __name__ == "__main__":
    main()
