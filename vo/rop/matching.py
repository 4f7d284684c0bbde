"""Stand-in correspondence front-end for the ROP estimator.

TO BE REPLACED by ``vo.frontend`` (owned by the front-end helper) once it exposes pairwise
matching. Kinds: ``"orb"``/``"sift"`` (detector + BFMatcher, Lowe ratio test and mutual
cross-check) and ``"klt"`` (goodFeaturesToTrack + pyramidal LK with a forward-backward check).
"""
from __future__ import annotations

import cv2
import numpy as np

KINDS = ("klt", "orb", "sift")
RATIO = 0.8          # Lowe ratio test
FB_MAX_PX = 1.0      # forward-backward LK error bound


def detect(img: np.ndarray, kind: str, max_features: int):
    """(H,W) uint8 -> features: (pts (N,2) float32, descriptors or None)."""
    if kind == "klt":
        c = cv2.goodFeaturesToTrack(img, max_features, 0.01, 8)
        pts = np.zeros((0, 2), np.float32) if c is None else c.reshape(-1, 2).astype(np.float32)
        return pts, None
    det = cv2.ORB_create(max_features) if kind == "orb" else cv2.SIFT_create(max_features)
    kps, desc = det.detectAndCompute(img, None)
    pts = np.array([k.pt for k in kps], np.float32).reshape(-1, 2)
    return pts, desc


def match(fa, fb, img_a: np.ndarray, img_b: np.ndarray, kind: str):
    """Correspondences between two images -> (p_a (M,2), p_b (M,2)) float64 pixels."""
    pts_a, desc_a = fa
    empty = (np.zeros((0, 2)), np.zeros((0, 2)))
    if len(pts_a) == 0:
        return empty
    if kind == "klt":
        p0 = pts_a.reshape(-1, 1, 2)
        p1, st, _ = cv2.calcOpticalFlowPyrLK(img_a, img_b, p0, None, winSize=(21, 21), maxLevel=3)
        if p1 is None:
            return empty
        pb, st_b, _ = cv2.calcOpticalFlowPyrLK(img_b, img_a, p1, None, winSize=(21, 21), maxLevel=3)
        fb_err = np.linalg.norm(pb.reshape(-1, 2) - pts_a, axis=1)
        ok = (st.ravel() == 1) & (st_b.ravel() == 1) & (fb_err < FB_MAX_PX)
        return pts_a[ok].astype(float), p1.reshape(-1, 2)[ok].astype(float)
    pts_b, desc_b = fb
    if desc_a is None or desc_b is None or len(pts_b) < 2 or len(pts_a) < 2:
        return empty
    norm = cv2.NORM_HAMMING if kind == "orb" else cv2.NORM_L2
    bf = cv2.BFMatcher(norm)
    ab = bf.knnMatch(desc_a, desc_b, k=2)
    ba = {m[0].queryIdx: m[0].trainIdx for m in bf.knnMatch(desc_b, desc_a, k=1) if m}
    ia, ib = [], []
    for m in ab:
        if len(m) == 2 and m[0].distance < RATIO * m[1].distance and ba.get(m[0].trainIdx) == m[0].queryIdx:
            ia.append(m[0].queryIdx)
            ib.append(m[0].trainIdx)
    return pts_a[ia].astype(float), pts_b[ib].astype(float)
