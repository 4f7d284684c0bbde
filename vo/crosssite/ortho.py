"""Orthorectified matching of a region pair (seed 001 §2.1-2.2, forward-backward: "project both
sites' images onto the ground plane and take the overlap").

Both left images of a region pair are resampled onto one common ground-plane grid: the plane
z = 0 of the current site's body frame at the dead-reckoning prior (``T_w_ground``), seen from
above (grid column = +x, grid row = -y of that frame, so the orthoimage is a proper, unmirrored
view and SIFT's rotation invariance covers the heading difference). The grid spans the overlap of
the two regions' ground footprints; its ground sample distance is the current image's footprint
resolution at the overlap centre, coarsened if needed to keep the grid within ``max_px`` per side.
Features are detected and matched on the two orthoimages and mapped back to original pixels of
each image by the inverse of its warp, as :mod:`vo.crosssite.zoom` maps the zoomed previous image back.

A view from 180 deg apart then differs by a rotation, a scale near 1 and the relief's parallax only,
instead of the up to 8x foreshortening between the perspective views of low-looking Navcams.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from rigs.geometry import inv_T
from vo.crosssite import asift, regions, zoom


@dataclass(frozen=True)
class OrthoGrid:
    """Ground grid: pixel (c, r) -> ground-frame (x0 + c gsd, y1 - r gsd, 0); ``size`` (width, height);
    ``overlap_xy`` (M,2) the ground-frame overlap polygon it spans."""

    T_w_ground: np.ndarray
    x0: float
    y1: float
    gsd_m: float
    size: tuple
    overlap_xy: np.ndarray

    def A(self) -> np.ndarray:
        """3x3 grid pixel -> ground-frame (x, y, 1)."""
        return np.array([[self.gsd_m, 0.0, self.x0], [0.0, -self.gsd_m, self.y1], [0.0, 0.0, 1.0]])

    def mask(self) -> np.ndarray:
        """uint8 mask (255) of the grid pixels inside the overlap polygon: the bounding grid's corners
        may lie outside a camera's footprint, even behind it, where the plane's warp is meaningless."""
        cr = (self.overlap_xy - [self.x0, self.y1]) / [self.gsd_m, -self.gsd_m]
        m = np.zeros((self.size[1], self.size[0]), np.uint8)
        cv2.fillConvexPoly(m, np.round(cr).astype(np.int32), 255)
        return m


def ground_homography(T_w_c: np.ndarray, K: np.ndarray, T_w_ground: np.ndarray) -> np.ndarray:
    """3x3 ground-frame (x, y, 1) on z = 0 -> image pixel (homogeneous): ``K [r1 r2 t]`` of ``T_c_ground``."""
    T_c_g = inv_T(T_w_c) @ T_w_ground
    return K @ np.column_stack([T_c_g[:3, 0], T_c_g[:3, 1], T_c_g[:3, 3]])


def image_to_grid(T_w_c: np.ndarray, K: np.ndarray, grid: OrthoGrid) -> np.ndarray:
    """3x3 warp image pixel -> grid pixel (for ``cv2.warpPerspective``; its inverse maps back)."""
    return np.linalg.inv(ground_homography(T_w_c, K, grid.T_w_ground) @ grid.A())


def box_footprint(T_w_c, K, box, T_w_ground, max_range_m) -> np.ndarray:
    """(M,2) ground-frame (x, y) where rays through a grid of pixels of ``box`` meet z = 0 of
    ``T_w_ground`` within ``max_range_m`` (:func:`vo.crosssite.regions.ground_coverage` on the box)."""
    u0, v0, u1, v1 = box
    K_box = K.copy()
    K_box[0, 2] -= u0
    K_box[1, 2] -= v0
    P_w = regions.ground_coverage(T_w_c, K_box, u1 - u0, v1 - v0, T_w_ground, max_range_m)
    return (P_w - T_w_ground[:3, 3]) @ T_w_ground[:3, :3][:, :2]


def footprint_gsd(T_w_c, K, T_w_ground, xy_g) -> float:
    """Ground metres per image pixel at ground-frame ``xy_g``: 1 / sqrt(|det d(u,v)/d(x,y)|) of the
    plane-to-image homography (the footprint's area scale)."""
    H = ground_homography(T_w_c, K, T_w_ground)
    q = H @ np.r_[xy_g, 1.0]
    J = (H[:2, :2] * q[2] - np.outer(q[:2], H[2, :2])) / q[2] ** 2
    return float(1.0 / np.sqrt(max(abs(np.linalg.det(J)), 1e-12)))


def overlap_grid(T_w_c_prev, T_w_c_cur, K, box_prev, box_cur, T_w_ground, max_range_m,
                 max_px: int = 1500) -> Optional[OrthoGrid]:
    """The common grid over the overlap of the two boxes' ground footprints (convex hulls,
    ``cv2.intersectConvexConvex``); None without overlap. GSD: the current image's footprint
    resolution at the overlap centre, coarsened to keep at most ``max_px`` per side."""
    a = box_footprint(T_w_c_prev, K, box_prev, T_w_ground, max_range_m)
    b = box_footprint(T_w_c_cur, K, box_cur, T_w_ground, max_range_m)
    if len(a) < 3 or len(b) < 3:
        return None
    area, inter = cv2.intersectConvexConvex(cv2.convexHull(a.astype(np.float32)),
                                            cv2.convexHull(b.astype(np.float32)))
    if area <= 0 or inter is None:
        return None
    xy = inter.reshape(-1, 2).astype(float)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    gsd = max(footprint_gsd(T_w_c_cur, K, T_w_ground, xy.mean(axis=0)), float((hi - lo).max()) / max_px)
    size = tuple(int(np.ceil(s / gsd)) + 1 for s in hi - lo)
    if min(size) < 16:
        return None
    return OrthoGrid(T_w_ground, float(lo[0]), float(hi[1]), gsd, size, xy)


def _detect_on_grid(img, T_w_c, K, grid, tilts, cfg) -> tuple:
    """(uv in original pixels (N,2), descriptors, warp image -> grid) of features on the orthoimage."""
    M = image_to_grid(T_w_c, K, grid)
    ortho, valid = zoom.warp_image(img, M, *grid.size)
    valid &= grid.mask()
    if not np.any(valid):
        return np.zeros((0, 2)), np.zeros((0, 128), np.float32), M
    uv_g, desc = asift.detect(ortho, valid, tilts, cfg.sift_features, cfg.use_asift, cfg.sift_contrast)
    return zoom.unwarp_points(uv_g, M), desc, M


def pair_matches(img_prev, T_w_c_prev, img_cur, T_w_c_cur, K, box_prev, box_cur, T_w_ground, tilts,
                 cfg) -> Optional[tuple]:
    """Orthorectified matching of one region pair -> (uv prev (M,2), uv cur (M,2), n features prev,
    n features cur), pixels of the original images inside their boxes; None without a common grid."""
    grid = overlap_grid(T_w_c_prev, T_w_c_cur, K, box_prev, box_cur, T_w_ground, cfg.region_max_range_m)
    if grid is None:
        return None
    uv_a, d_a, _ = _detect_on_grid(img_prev, T_w_c_prev, K, grid, tilts, cfg)
    uv_b, d_b, _ = _detect_on_grid(img_cur, T_w_c_cur, K, grid, tilts, cfg)
    ab = asift.match(d_a, d_b, cfg.ratio)
    if len(ab):
        ab = ab[regions.in_box(uv_a[ab[:, 0]], box_prev) & regions.in_box(uv_b[ab[:, 1]], box_cur)]
    return uv_a[ab[:, 0]], uv_b[ab[:, 1]], len(uv_a), len(uv_b)


def ortho_rows(prev, T_w_b_prev, cur, boxes, imgs_p, imgs_c, tilts, cfg) -> tuple:
    """Tie rows ``(i, u_prev, v_prev, j, u_cur, v_cur)`` over the region pairs ``boxes`` matched on
    their orthoimages -> (rows, n previous features, n current features, n rectified pairs)."""
    K = cur.cal.K
    rows, n_p, n_c, n_pairs = [], 0, 0, 0
    for (i, j), (bp, bc) in boxes.items():
        got = pair_matches(imgs_p[i], T_w_b_prev @ prev.pairs[i].T_b_c0, imgs_c[j],
                           cur.T_w_b_prior @ cur.pairs[j].T_b_c0, K, bp, bc, cur.T_w_b_prior, tilts, cfg)
        if got is None:
            continue
        uv_a, uv_b, na, nb = got
        n_p, n_c, n_pairs = n_p + na, n_c + nb, n_pairs + 1
        rows.extend((i, *a, j, *b) for a, b in zip(uv_a, uv_b))
    return rows, n_p, n_c, n_pairs
