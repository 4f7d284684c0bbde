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
                             flow_pred.max(), float(np.mean(flow_pred > reach)), float(np.median(disp[ok]))))
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
    print(f"rotation error per step: median {np.median(a[:, 4]):.4f} deg, max {a[:, 4].max():.4f} deg")
    v1, v2 = np.concatenate(vd_klt), np.concatenate(vd_orb)
    print(f"vertical disparity, LK matches ({len(v1)}): median {np.median(v1):+.3f} px, robust std "
          f"{robust_std(v1):.3f} px, |dv| > 1 px {np.mean(np.abs(v1) > 1):.3f}")
    print(f"vertical disparity, ORB matches ({len(v2)}): median {np.median(v2):+.3f} px, robust std "
          f"{robust_std(v2):.3f} px, |dv| > 1 px {np.mean(np.abs(v2) > 1):.3f}")
    print(f"predicted flow: median of step medians {np.median(a[:, 7]):.1f} px, max p95 {a[:, 8].max():.1f} px, "
          f"max {a[:, 9].max():.1f} px; share beyond reach {reach} px: mean {a[:, 10].mean():.4f}, max {a[:, 10].max():.4f}")
    if args.csv:
        np.savetxt(args.csv, a, delimiter=",", header=hdr.replace("  ", ","), fmt="%.5f")


if __name__ == "__main__":
    main()
