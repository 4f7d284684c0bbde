"""Tiny exact renderer for tests: textured planes seen by a pinhole stereo rig (no distortion), z-buffered.

Each plane is ``(origin_o (3,), axis_u_o (3,), axis_v_o (3,), texel_m, texture (Ht,Wt) uint8)``: texel
``(i, j)`` (column i, row j) sits at ``origin + i*texel*axis_u + j*texel*axis_v`` in frame ``o``.
A camera at ``T_o_c`` sees it through the homography ``H = K [R_c_o a, R_c_o b, R_c_o origin + t_c_o]``.
"""
from __future__ import annotations

import cv2
import numpy as np

from rigs.geometry import inv_T


def random_texture(rng: np.random.Generator, width: int, height: int, blur_texels: float = 2.0) -> np.ndarray:
    """(height, width) uint8 blurred random texture stretched to 20..235."""
    t = cv2.GaussianBlur(rng.random((height, width)).astype(np.float32), (0, 0), blur_texels)
    t = (t - t.min()) / max(float(t.max() - t.min()), 1e-9)
    return (20 + 215 * t).astype(np.uint8)


def box_scene(rng: np.random.Generator, texel_m: float = 0.02) -> list:
    """A corridor in front of the first camera (frame o = OpenCV camera, z forward, y down):
    back wall z=8, floor y=1.2, side walls x=+-2.5; each 16 m deep."""
    def tex(w_m, h_m):
        return random_texture(rng, int(w_m / texel_m), int(h_m / texel_m))
    ex, ey, ez = np.eye(3)
    return [
        (np.array([-2.5, -2.0, 8.0]), ex, ey, texel_m, tex(5.0, 3.2)),          # back wall
        (np.array([-2.5, 1.2, -2.0]), ex, ez, texel_m, tex(5.0, 10.0)),         # floor
        (np.array([-2.5, -2.0, -2.0]), ez, ey, texel_m, tex(10.0, 3.2)),        # left wall
        (np.array([2.5, -2.0, -2.0]), ez, ey, texel_m, tex(10.0, 3.2)),         # right wall
    ]


def render(planes: list, camera, T_o_c: np.ndarray, background: int = 0) -> np.ndarray:
    """(H,W) uint8 image of ``planes`` seen by ``camera`` (rigs.Camera, its distortion ignored) at ``T_o_c``."""
    K, w, h = camera.K, camera.width, camera.height
    T_c_o = inv_T(T_o_c)
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays = np.stack([(uu - K[0, 2]) / K[0, 0], (vv - K[1, 2]) / K[1, 1], np.ones_like(uu)], axis=-1)
    img = np.full((h, w), float(background))
    zbuf = np.full((h, w), np.inf)
    for origin, a, b, s, tex in planes:
        o_c = T_c_o[:3, :3] @ origin + T_c_o[:3, 3]
        a_c, b_c = T_c_o[:3, :3] @ a, T_c_o[:3, :3] @ b
        n_c = np.cross(a_c, b_c)
        denom = rays @ n_c
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(np.abs(denom) > 1e-12, (n_c @ o_c) / denom, np.inf)
        H = K @ np.column_stack([a_c * s, b_c * s, o_c])
        warped = cv2.warpPerspective(tex.astype(np.float32), H, (w, h), flags=cv2.INTER_LINEAR,
                                     borderMode=cv2.BORDER_CONSTANT, borderValue=-1.0)
        vis = (z > 0.05) & (z < zbuf) & (warped >= 0)
        img[vis], zbuf[vis] = warped[vis], z[vis]
    return np.clip(np.round(img), 0, 255).astype(np.uint8)
