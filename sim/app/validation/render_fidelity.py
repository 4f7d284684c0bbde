"""Does rendered texture move with the geometry? Rendered frame k+1 against an exact warp of frame k.

Every pixel of frame k+1 is back-projected with its rendered depth, moved by the true relative pose
into frame k, projected with the rig model (distortion included) and sampled there (bicubic): the
warp is what frame k+1 would look like if the texture were painted on the surfaces. Corners of the
warp are aligned to the rendered frame k+1 by the affine LK refinement (:mod:`vo.frontend.affine_lk`,
started at zero displacement); their mean displacement is the texture's motion against the
geometry (zero for a faithful renderer). Used by docs/studies/render_fidelity_check.py and
tests/test_render_supersample.py.
"""
from __future__ import annotations

import cv2
import numpy as np

from sim.app.validation.exact_points import backproject, project
from vo.frontend.affine_lk import refine_affine
from rigs.geometry import inv_T


def exact_warp(img_k: np.ndarray, depth_k1: np.ndarray, T_k_k1: np.ndarray, camera) -> np.ndarray:
    """(H,W) image: ``img_k`` (H,W) resampled at where each pixel of frame k+1 (depth ``depth_k1``
    (H,W) m, ``inf`` = sky) is seen in frame k; ``T_k_k1`` (4,4) pose of camera k+1 in camera k."""
    H, W = depth_k1.shape
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    X1 = backproject(camera, np.c_[u.ravel(), v.ravel()], depth_k1.astype(np.float64).ravel())
    X1[~np.all(np.isfinite(X1), axis=1)] = 1e6            # sky: sampled anywhere, masked by the caller
    m = project(camera, inv_T(T_k_k1), X1)[0].reshape(H, W, 2).astype(np.float32)
    return cv2.remap(img_k, m[..., 0], m[..., 1], cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)


def texture_motion(renderer, T_w_b_pairs, camera_index: int = 0, v_min: float = 330.0,
                   max_corners: int = 800) -> np.ndarray:
    """(N,2) displacement (u, v) px of rendered frame k+1 against the exact warp of frame k, over the
    corners below image row ``v_min`` (ground, for a forward-looking rig) of every ``(T_w_b_k,
    T_w_b_k1)`` pair. ``renderer``: a :class:`sim.render.StereoRenderer` with ``depth=True`` and
    ``gray=True``. Corners whose alignment fails or moves > 1 px are left out."""
    cam = renderer.rig.cameras[camera_index]
    out = []
    for T_w_b_k, T_w_b_k1 in T_w_b_pairs:
        f0, f1 = renderer.render(T_w_b_k), renderer.render(T_w_b_k1)
        T_k_k1 = inv_T(T_w_b_k @ cam.T_b_c_array) @ (T_w_b_k1 @ cam.T_b_c_array)
        warp = exact_warp(f0.images[camera_index], f1.depth[camera_index], T_k_k1, cam)
        q = cv2.goodFeaturesToTrack(warp, max_corners, 0.01, 8, blockSize=3)
        if q is None:
            continue
        q = q.reshape(-1, 2).astype(np.float64)
        q = q[(q[:, 1] > v_min) & (q[:, 1] < cam.height - 15) & (q[:, 0] > 15) & (q[:, 0] < cam.width - 15)]
        q1, _, ok = refine_affine(warp, f1.images[camera_index], q, q.copy())
        d = (q1 - q)[ok]
        out.append(d[np.all(np.abs(d) < 1.0, axis=1)])
    return np.vstack(out) if out else np.zeros((0, 2))
