"""ASIFT feature matching between the left images of two sites (seed 001 §2.2), with the tilt set
reduced by the dead-reckoning prior.

ASIFT (Morel & Yu 2009) simulates views with tilts ``t = sqrt(2)^k`` and, per tilt, rolls in steps
of ``72 deg / t`` over [0, 180) and runs SIFT on each (``cv2.AffineFeature`` over ``cv2.SIFT``). The
prior predicts the transition tilt between the two views of the ground: the singular-value ratio of
the local affine map ``J_cur J_prev^-1`` where ``J`` is the Jacobian of ground-plane ``(x, y)`` ->
pixel at the overlap centre. Simulating tilts up to ``t`` on both images covers transition tilts up
to ``t^2`` (Morel & Yu), so only tilts up to the first ``sqrt(2)^k >= sqrt(tau)`` are simulated: the
paper's reduction of the tilt set (which it reports halves the matching time).

Matching is Lowe's ratio test on exact nearest neighbours (:func:`match`); :class:`DetectionCache`
carries the SIFT pass's features and neighbours into the ASIFT fallback of the same site pair.
"""
from __future__ import annotations

import hashlib
import threading

import cv2
import numpy as np

from rigs.geometry import inv_T

SQRT2 = float(np.sqrt(2.0))


def plane_jacobian(T_w_c: np.ndarray, K: np.ndarray, p_w: np.ndarray) -> np.ndarray:
    """(2,2) d(u, v) / d(x_w, y_w) of a point moving on the horizontal plane through ``p_w``."""
    T_c_w = inv_T(T_w_c)
    P_c = T_c_w[:3, :3] @ p_w + T_c_w[:3, 3]
    x, y, z = P_c
    J_proj = np.array([[K[0, 0] / z, 0, -K[0, 0] * x / z ** 2], [0, K[1, 1] / z, -K[1, 1] * y / z ** 2]])
    return J_proj @ T_c_w[:3, :2]


def transition(T_w_c_prev, T_w_c_cur, K, p_w) -> tuple:
    """(transition tilt >= 1, scale cur/prev) between the two views of the ground at ``p_w``."""
    M = plane_jacobian(T_w_c_cur, K, p_w) @ np.linalg.inv(plane_jacobian(T_w_c_prev, K, p_w))
    s = np.linalg.svd(M, compute_uv=False)
    return float(s[0] / s[1]), float(np.sqrt(s[0] * s[1]))


def tilt_set(predicted_tilt: float, max_tilt: float) -> list:
    """ASIFT tilts ``sqrt(2)^k`` up to the first one >= ``sqrt(predicted_tilt)`` (at least up to
    sqrt 2), never beyond ``max_tilt``."""
    tilts = [1.0]
    need = max(np.sqrt(max(predicted_tilt, 1.0)), SQRT2)
    while tilts[-1] * SQRT2 <= max_tilt + 1e-9 and tilts[-1] < need - 1e-9:
        tilts.append(tilts[-1] * SQRT2)
    return tilts


def view_params(tilts) -> tuple:
    """Per-view (tilts, rolls in degrees) lists for ``AffineFeature.setViewParams``."""
    vt, vr = [], []
    for t in tilts:
        if t == 1.0:
            vt.append(1.0)
            vr.append(0.0)
            continue
        for r in np.arange(0.0, 180.0, 72.0 / t):
            vt.append(float(t))
            vr.append(float(r))
    return vt, vr


def detect(img: np.ndarray, mask, tilts, n_features: int, asift: bool = True, contrast: float = 0.04,
           cache: "DetectionCache | None" = None) -> tuple:
    """(keypoints uv (N,2), descriptors (N,128) float32) of ASIFT with ``tilts`` (plain SIFT when
    ``asift`` is False) inside ``mask``; ``contrast`` is SIFT's contrast threshold (low-contrast
    regolith needs less than OpenCV's 0.04). ASIFT's first view (tilt 1, roll 0) is plain SIFT on the
    image itself, so it is detected as such (from ``cache`` when that image and mask were seen
    before) and the other views are appended in ``cv2.AffineFeature``'s order: the same features in
    the same order as one ``AffineFeature`` call."""
    sift_part = _cached(cache, ("sift", n_features, contrast), img, mask,
                        lambda: _detect(cv2.SIFT_create(nfeatures=int(n_features), contrastThreshold=float(contrast)),
                                        img, mask))
    vt, vr = view_params(tilts)
    if not asift or len(vt) == 1:
        return sift_part
    if (vt[0], vr[0]) != (1.0, 0.0):
        raise ValueError(f"ASIFT tilts must start at 1, got {list(tilts)}")
    det = cv2.AffineFeature.create(cv2.SIFT_create(nfeatures=int(n_features), contrastThreshold=float(contrast)))
    det.setViewParams(vt[1:], vr[1:])
    extra = _detect(det, img, mask)
    return np.vstack([sift_part[0], extra[0]]), np.vstack([sift_part[1], extra[1]])


def _detect(det, img, mask) -> tuple:
    kps, desc = det.detectAndCompute(img, mask)
    if desc is None or len(kps) == 0:
        return np.zeros((0, 2)), np.zeros((0, 128), np.float32)
    return np.array([k.pt for k in kps], float), np.asarray(desc, np.float32)


class DetectionCache:
    """Work shared by the passes of one site pair: plain SIFT features per (settings, image content,
    mask content) and nearest-neighbour results per (query rows, train set). The SIFT pass and the
    ASIFT fallback see the same current images and zoomed previous images; ASIFT's tilt-1 view is
    the SIFT pass's detection, and those rows' nearest neighbours among the same current features
    are the SIFT pass's. Keys are content digests, so a changed image, mask or descriptor set is never
    served a stale result. ASIFT's other views are not kept (one pass uses them). Safe to share
    between threads."""

    def __init__(self):
        self._features, self._knn = {}, {}
        self._lock = threading.Lock()
        self.hits = 0

    def features(self, key, compute):
        with self._lock:
            if key in self._features:
                self.hits += 1
                return self._features[key]
        out = compute()
        with self._lock:
            self._features.setdefault(key, out)
        return out

    def nearest(self, desc_a: np.ndarray, desc_b: np.ndarray) -> tuple:
        """:func:`_two_nearest` of ``desc_a`` in ``desc_b``, the leading rows of ``desc_a`` that an
        earlier call matched against the same ``desc_b`` taken from that call."""
        key_b = _digest(desc_b)
        with self._lock:
            known = sorted(self._knn.get(key_b, {}).items(), key=lambda kv: -kv[0][0])
        for (n, key_a), res in known:
            if n <= len(desc_a) and _digest(desc_a[:n]) == key_a:
                with self._lock:
                    self.hits += 1
                rest = _two_nearest(desc_a[n:], desc_b) if n < len(desc_a) else ()
                return tuple(np.concatenate([x, y]) for x, y in zip(res, rest)) if rest else res
        res = _two_nearest(desc_a, desc_b)
        with self._lock:
            self._knn.setdefault(key_b, {})[(len(desc_a), _digest(desc_a))] = res
        return res


def _digest(a) -> bytes:
    if a is None:
        return b""
    a = np.ascontiguousarray(a)
    h = hashlib.blake2b(f"{a.shape} {a.dtype.str}".encode(), digest_size=16)
    h.update(a.data)
    return h.digest()


def _cached(cache, settings, img, mask, compute):
    if cache is None:
        return compute()
    return cache.features((settings, _digest(img), _digest(mask)), compute)


def match(desc_a: np.ndarray, desc_b: np.ndarray, ratio: float, cache: DetectionCache = None) -> np.ndarray:
    """(M,2) index pairs (a, b): Lowe's ratio test, then one match per b (the best); nearest
    neighbours of rows already matched against ``desc_b`` from ``cache``."""
    if len(desc_a) < 2 or len(desc_b) < 2:
        return np.zeros((0, 2), int)
    d1, d2, j1 = _two_nearest(desc_a, desc_b) if cache is None else cache.nearest(desc_a, desc_b)
    best = {}
    for a in np.flatnonzero(d1 < ratio * d2):
        b = int(j1[a])
        if b not in best or d1[a] < best[b][1]:
            best[b] = (int(a), d1[a])
    return np.array(sorted((a, b) for b, (a, _) in best.items()), int).reshape(-1, 2)


GEMM_BLOCK = 1 << 22        # float32 elements of one block of the distance matrix (16 MiB)


def _two_nearest(desc_a: np.ndarray, desc_b: np.ndarray) -> tuple:
    """Per row of ``desc_a``: the nearest and second-nearest L2 distances in ``desc_b`` and the nearest's
    index ((N,), (N,), (N,)); second distance inf when ``desc_b`` has one row. Byte-valued descriptors
    (OpenCV's SIFT: integers 0-255 in float32) by :func:`_two_nearest_gemm`, others by ``cv2.BFMatcher``."""
    if _byte_valued(desc_a) and _byte_valued(desc_b):
        return _two_nearest_gemm(desc_a, desc_b)
    return _two_nearest_bf(desc_a, desc_b)


def _byte_valued(d: np.ndarray) -> bool:
    return d.dtype == np.float32 and d.size > 0 and d.min() >= 0 and d.max() <= 255 and np.array_equal(d, np.rint(d))


def _two_nearest_gemm(desc_a: np.ndarray, desc_b: np.ndarray) -> tuple:
    """:func:`_two_nearest` of byte-valued descriptors by one matrix product per block of rows,
    ``[a 1] @ [-2 b^T ; |b|^2]``. Every product and partial sum is an integer below 2^24 (128 x 255^2
    x 2), which float32 holds exactly, so the squared distances are exact whatever the summation
    order: the same neighbours, distances and tie order (lowest index first) as ``cv2.BFMatcher``
    (:func:`_two_nearest_bf`), 3-4x faster on one thread (``cv2.gemm`` follows ``cv2.setNumThreads``)."""
    n, m = len(desc_a), len(desc_b)
    bT = np.vstack([-2.0 * desc_b.T, np.einsum("ij,ij->i", desc_b, desc_b)[None]]).astype(np.float32)
    aa = np.einsum("ij,ij->i", desc_a, desc_a)
    a1 = np.hstack([desc_a, np.ones((n, 1), np.float32)])
    d1, d2, j1 = np.full(n, np.inf), np.full(n, np.inf), np.zeros(n, int)
    step = max(1, GEMM_BLOCK // m)
    for s in range(0, n, step):
        g = cv2.gemm(a1[s:s + step], bT, 1.0, None, 0.0)
        r = np.arange(len(g))
        k1 = g.argmin(axis=1)
        d1[s:s + step], j1[s:s + step] = np.sqrt(g[r, k1] + aa[s:s + step]), k1
        if m > 1:
            g[r, k1] = np.inf
            d2[s:s + step] = np.sqrt(g[r, g.argmin(axis=1)] + aa[s:s + step])
    return d1, d2, j1


MAX_TRAIN_ROWS = 1 << 17    # cv2.BFMatcher refuses a train set of 2^18 rows or more (IMGIDX_ONE)


def _two_nearest_bf(desc_a: np.ndarray, desc_b: np.ndarray) -> tuple:
    """:func:`_two_nearest` by ``cv2.BFMatcher``, ``desc_b`` in chunks of :data:`MAX_TRAIN_ROWS`."""
    n = len(desc_a)
    d = np.full((n, 4), np.inf)
    j = np.zeros((n, 4), int)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    for start in range(0, len(desc_b), MAX_TRAIN_ROWS):
        chunk = desc_b[start:start + MAX_TRAIN_ROWS]
        for m in matcher.knnMatch(desc_a, chunk, k=min(2, len(chunk))):
            for r, x in enumerate(m[:2]):
                d[x.queryIdx, 2 + r], j[x.queryIdx, 2 + r] = x.distance, start + x.trainIdx
        order = np.argsort(d, axis=1, kind="stable")
        d, j = np.take_along_axis(d, order, 1), np.take_along_axis(j, order, 1)
        d[:, 2:], j[:, 2:] = np.inf, 0
    return d[:, 0], d[:, 1], j[:, 0]
