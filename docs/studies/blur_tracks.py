"""The blur-truth check's data and measurements, shared by ``tests/test_blur_truth.py`` and
``blur_truth_check.py``: the two datasets' settings (sharp and blurred 0.35 s of ``indoor-short``), corners of
a sharp frame lifted with the written depth, KLT into the next frame, and a PnP with its information matrix."""
import cv2
import numpy as np

from rigs.geometry import inv_T

EXPOSURE_MS = 80.0
COMMON = ["duration_s=0.35", "ideal=true", "depth=true", "motion.start_speed_mps=0.8",
          "motion.vibration_pitch_deg=0", "motion.vibration_roll_deg=0", "motion.vibration_yaw_deg=0",
          "motion.vibration_heave_m=0"]
BLUR = [f"camera.exposure_ms={EXPOSURE_MS}", "camera.blur_subframes=9"]


def rt(T_w_c: np.ndarray) -> np.ndarray:
    """[rvec, tvec] of T_c_w (OpenCV's extrinsics) of a camera pose T_w_c."""
    T_c_w = inv_T(T_w_c)
    return np.concatenate([cv2.Rodrigues(T_c_w[:3, :3])[0].ravel(), T_c_w[:3, 3]])


def K_matrix(cam) -> np.ndarray:
    return np.array([[cam.fx, 0.0, cam.cx], [0.0, cam.fy, cam.cy], [0.0, 0.0, 1.0]])


def lifted_features(sharp, k: int):
    """Corners of sharp frame k at integer pixels and their world points (written depth, true pose of k)."""
    cam, img, depth = sharp.rig.cameras[0], sharp.frame(k).left, sharp.depth(k)
    px = np.rint(cv2.goodFeaturesToTrack(img, 400, 0.01, 15, blockSize=7).reshape(-1, 2))
    z = depth[px[:, 1].astype(int), px[:, 0].astype(int)]
    keep = np.isfinite(z)
    px, z = px[keep], z[keep]
    # undistorted rays of the pixel centres (the renderer distorts exactly with the rig's model)
    xy = cv2.undistortPoints(px.reshape(-1, 1, 2), K_matrix(cam), np.asarray(cam.dist)).reshape(-1, 2)
    p_c = np.column_stack([xy, np.ones(len(xy))]) * z[:, None]
    T_w_c = sharp.groundtruth_cam0().T[k]
    return px.astype(np.float32), p_c @ T_w_c[:3, :3].T + T_w_c[:3, 3]


def track(img0, img1, px):
    """KLT from img0 to img1 -> (positions, kept): kept tracks return to within 0.3 px when tracked back (a
    check that does not use the truth, so it cannot favour one time convention)."""
    lk = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-3))
    q, st, _ = cv2.calcOpticalFlowPyrLK(img0, img1, px.reshape(-1, 1, 2), None, **lk)
    back, st_b, _ = cv2.calcOpticalFlowPyrLK(img1, img0, q, None, **lk)
    fb = np.linalg.norm(back.reshape(-1, 2) - px, axis=1)
    return q.reshape(-1, 2).astype(float), (st.ravel() == 1) & (st_b.ravel() == 1) & (fb < 0.3)


def pnp(p_w, q, cam, x0):
    """PnP (Levenberg-Marquardt from x0) -> (x = [rvec, tvec], information J^T J / sigma^2, sigma px) with sigma
    the post-fit residual scale sqrt(SSR / (2n - 6)), which does not depend on the truth."""
    K, dist = K_matrix(cam), np.asarray(cam.dist)
    ok, rvec, tvec = cv2.solvePnP(p_w, q, K, dist, x0[:3].copy(), x0[3:].copy(), useExtrinsicGuess=True,
                                  flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise RuntimeError("solvePnP failed")
    proj, J = cv2.projectPoints(p_w, rvec, tvec, K, dist)
    sigma = np.sqrt(((proj.reshape(-1, 2) - q) ** 2).sum() / (2 * len(q) - 6))
    J = J[:, :6]
    return np.concatenate([rvec.ravel(), tvec.ravel()]), J.T @ J / sigma ** 2, sigma


def camera_centre(x) -> np.ndarray:
    return -cv2.Rodrigues(x[:3])[0].T @ x[3:]
