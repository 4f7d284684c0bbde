"""Up-to-scale structure from motion over the start's keyframes (VINS-Mono's ``relativePose`` +
``GlobalSFM``), the first step of :mod:`vo.vins.vi_init`.

Essential matrix (OpenCV RANSAC) between a reference keyframe and a second view (the newest, or when no keyframe
pairs with it the next-newest that does), triangulation, PnP (RANSAC, then iterative refinement) for the other
keyframes (each one posed before the reference triangulating its tracks with every posed keyframe), triangulation
of every remaining track, then a full gtsam bundle adjustment over the window (Huber,
Levenberg-Marquardt), a second one without the observations beyond ``REJECT_PX`` (moving objects, KLT slips).
Frame ``v`` = the camera frame of the reference keyframe.
"""
from __future__ import annotations

import cv2
import gtsam
import numpy as np

MIN_COMMON = 20          # features shared by the reference and the second view (VINS-Mono: 20)
MIN_POSE_INLIERS = 12    # essential-matrix inliers of the reference pair (VINS-Mono: 12)
BA_SIGMA_PX = 1.0        # reprojection std of the SfM bundle adjustment at the virtual focal length
REJECT_PX = 3.0          # observations beyond this after the first BA are dropped (moving objects, KLT slips)


def _common(a, b):
    common, ia, ib = np.intersect1d(a.ids, b.ids, assume_unique=True, return_indices=True)
    return common, a.xy[ia], b.xy[ib]


def _triangulate(T_c_v_a, T_c_v_b, xa, xb):
    P = cv2.triangulatePoints(T_c_v_a[:3], T_c_v_b[:3], xa.T.astype(float), xb.T.astype(float))
    X = (P[:3] / P[3]).T
    za = (T_c_v_a[:3, :3] @ X.T).T[:, 2] + T_c_v_a[2, 3]
    zb = (T_c_v_b[:3, :3] @ X.T).T[:, 2] + T_c_v_b[2, 3]
    return X, (za > 0) & (zb > 0) & np.all(np.isfinite(X), axis=1)


def sfm(frames, min_parallax_px: float, virtual_focal: float):
    """-> (ref, (T_c_v (n,4,4), points {track: p_v})) or None when no keyframe pair qualifies.

    As VINS-Mono's ``relativePose`` + ``GlobalSFM::construct``: the reference is the oldest keyframe with at
    least ``MIN_COMMON`` features in common with the newest, mean parallax >= ``min_parallax_px`` (at the
    virtual focal length) and a relative pose with more than ``MIN_POSE_INLIERS`` RANSAC inliers (later
    candidates are tried when one fails); PnP (RANSAC) chains the other keyframes, then a full bundle
    adjustment over the window (gtsam LM), observations beyond ``REJECT_PX`` dropped, and a second BA.
    When no keyframe qualifies with the newest, the next-newest keyframes are tried in turn as the second
    view (:func:`reference_pair`); the keyframes after it are then chained forward by PnP as well.
    A keyframe posed by PnP before the reference triangulates its tracks with every keyframe posed so far, not
    only with the reference (VINS-Mono's ``GlobalSFM``; a deviation): the keyframe of a start from rest shares
    its long tracks with the next keyframes, which often lose them before the reference (measured on an
    urban-dynamic start from rest: 9 points, 5 PnP inliers, with the reference's triangulation only; 28 and 17
    with this)."""
    pair = reference_pair(frames, min_parallax_px, virtual_focal)
    if pair is None:
        return None
    ref, b, rel = pair
    n = len(frames)
    T = np.full((n, 4, 4), np.nan)
    T[ref], T[b] = np.eye(4), rel
    points = {}
    _add_points(points, frames, T, ref, b)
    for k in range(ref + 1, b):
        if not _pnp(frames[k], points, T, k):
            return None
        _add_points(points, frames, T, k, b)
    for k in range(ref + 1, b):              # tracks that end before the second view, for the PnP below
        _add_points(points, frames, T, k, ref)
    for k in range(b + 1, n):                # keyframes after the second view (none when it is the newest)
        if not _pnp(frames[k], points, T, k):
            return None
        _add_points(points, frames, T, ref, k)
        _add_points(points, frames, T, b, k)
    for k in range(ref - 1, -1, -1):
        if not _pnp(frames[k], points, T, k):
            return None
        for c in range(n - 1, k, -1):        # with every posed keyframe, widest baseline first (a deviation)
            _add_points(points, frames, T, k, c)
    for a in range(n - 1):                   # the remaining tracks, widest baseline first
        for c in range(n - 1, a, -1):
            _add_points(points, frames, T, a, c)
    T, points = _bundle_adjust(frames, T, points, ref, virtual_focal, second=b)
    return ref, _bundle_adjust(frames, T, points, ref, virtual_focal, REJECT_PX, second=b)


def reference_pair(frames, min_parallax_px: float, virtual_focal: float):
    """-> (a, b, T_c_v of b with a = v, unit baseline) or None: the two views the SfM starts from.

    VINS-Mono's ``relativePose``: b is the newest keyframe, a the oldest with >= ``MIN_COMMON`` features in
    common, mean parallax >= ``min_parallax_px`` and a relative pose with > ``MIN_POSE_INLIERS`` inliers. When
    none qualifies, b steps back to the next-newest keyframe and so on (a later reference than VINS-Mono's
    window would wait for): in traffic the newest keyframe often shares fewer than ``MIN_COMMON`` static
    features at 30 px of parallax with every older one while an earlier pair of the same window qualifies."""
    for b in range(len(frames) - 1, 0, -1):
        for a in range(b):
            ids, xa, xb = _common(frames[a], frames[b])
            if len(ids) < MIN_COMMON or np.linalg.norm(xa - xb, axis=1).mean() * virtual_focal < min_parallax_px:
                continue
            rel = _relative_pose(xa, xb, virtual_focal)
            if rel is not None:
                return a, b, rel
    return None


def _relative_pose(xa, xb, virtual_focal):
    """T_c_v of b with a = v, unit baseline (essential matrix, OpenCV RANSAC at 0.3 px); None if too few inliers."""
    E, inl = cv2.findEssentialMat(xa, xb, np.eye(3), cv2.RANSAC, 0.999, 0.3 / virtual_focal)
    if E is None or E.shape != (3, 3):
        return None
    n_in, R, t, inl = cv2.recoverPose(E, xa, xb, np.eye(3), mask=inl)
    if n_in <= MIN_POSE_INLIERS:
        return None
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t.ravel()
    return T


def _add_points(points, frames, T, a, b):
    if a == b:
        return
    ids, xa, xb = _common(frames[a], frames[b])
    new = np.array([i not in points for i in ids], bool)
    if not new.any():
        return
    X, ok = _triangulate(T[a], T[b], xa[new], xb[new])
    for i, p in zip(ids[new][ok], X[ok]):
        points[int(i)] = p


def _pnp(frame, points, T, k) -> bool:
    have = [(p, xy) for i, xy in zip(frame.ids, frame.xy) if (p := points.get(int(i))) is not None]
    if len(have) < 10:
        return False
    obj = np.array([h[0] for h in have], float)
    img = np.array([h[1] for h in have], float)
    ok, rvec, tvec, inl = cv2.solvePnPRansac(obj, img, np.eye(3), None, reprojectionError=2.0 / 460.0,
                                             iterationsCount=500, flags=cv2.SOLVEPNP_EPNP)
    if not ok or inl is None or len(inl) < 8:
        return False
    ok, rvec, tvec = cv2.solvePnP(obj[inl.ravel()], img[inl.ravel()], np.eye(3), None, rvec, tvec, True,
                                  cv2.SOLVEPNP_ITERATIVE)
    T[k] = np.eye(4)
    T[k][:3, :3], T[k][:3, 3] = cv2.Rodrigues(rvec)[0], tvec.ravel()
    return True


def _bundle_adjust(frames, T_c_v, points, ref, virtual_focal, reject_px: float = 0.0, second: int = -1):
    """Full gtsam BA over the window on normalized coordinates (K = virtual focal), poses T_v_c, Huber loss;
    gauge: the reference pose by a tight prior, the scale left to LM's damping and then restored to the
    baseline between the reference and ``second`` (default the newest keyframe). With ``reject_px`` > 0, observations reprojecting farther than that (pixels at
    the virtual focal length) at the input estimate are left out. -> (T_c_v, points)."""
    from gtsam.symbol_shorthand import L, X
    K = gtsam.Cal3_S2(virtual_focal, virtual_focal, 0.0, 0.0, 0.0)
    noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(1.345),
                                           gtsam.noiseModel.Isotropic.Sigma(2, BA_SIGMA_PX))
    g, v = gtsam.NonlinearFactorGraph(), gtsam.Values()
    used = set()
    for k, fr in enumerate(frames):
        v.insert(X(k), gtsam.Pose3(np.linalg.inv(T_c_v[k])))
        for i, xy in zip(fr.ids.tolist(), fr.xy):
            p = points.get(i)
            if p is None:
                continue
            if reject_px > 0:
                p_c = T_c_v[k][:3, :3] @ p + T_c_v[k][:3, 3]
                if p_c[2] <= 0 or np.linalg.norm(p_c[:2] / p_c[2] - xy) * virtual_focal > reject_px:
                    continue
            g.add(gtsam.GenericProjectionFactorCal3_S2(xy * virtual_focal, noise, X(k), L(i), K))
            used.add(i)
    for i in used:
        v.insert(L(i), gtsam.Point3(*points[i]))
    g.add(gtsam.PriorFactorPose3(X(ref), gtsam.Pose3(), gtsam.noiseModel.Isotropic.Sigma(6, 1e-6)))
    last = second % len(frames)
    d0 = float(np.linalg.norm(np.linalg.inv(T_c_v[last])[:3, 3]))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(100)
    out = gtsam.LevenbergMarquardtOptimizer(g, v, params).optimize()
    T = np.array([np.linalg.inv(out.atPose3(X(k)).matrix()) for k in range(len(frames))])
    d1 = float(np.linalg.norm(np.linalg.inv(T[last])[:3, 3]))
    f = d0 / d1 if d1 > 0 else 1.0
    T[:, :3, 3] *= f
    return T, {i: out.atPoint3(L(i)) * f for i in used}
