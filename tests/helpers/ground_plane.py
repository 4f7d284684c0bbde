"""A synthetic textured ground plane for the cross-site matching tests (tests/test_crosssite_zoom.py,
tests/test_crosssite_ortho.py): regolith-like texture and down-looking Navcam poses."""
import cv2
import numpy as np

from rigs.geometry import make_T


def regolith_texture(seed: int, nx: int, ny: int, n_blobs: int) -> np.ndarray:
    """(ny, nx) uint8: noise at 2, 8 and 32 texels plus ``n_blobs`` dark/bright discs (rocks, pits)."""
    rng = np.random.default_rng(seed)
    t = np.zeros((ny, nx), np.float32)
    for sigma, w in ((2, 0.6), (8, 1.0), (32, 1.2)):
        n = cv2.GaussianBlur(rng.standard_normal((ny, nx)).astype(np.float32), (0, 0), sigma)
        t += w * n / n.std()
    for _ in range(n_blobs):
        cx, cy, r = rng.integers(0, nx), rng.integers(0, ny), int(rng.integers(4, 25))
        cv2.circle(t, (int(cx), int(cy)), r, float(rng.choice([-3.0, 3.0])), -1)
    t = cv2.GaussianBlur(t, (0, 0), 1.5)
    return np.clip(100 + 30 * t, 0, 255).astype(np.uint8)


def navcam_pose(x_m: float, yaw_rad: float = 0.0, tilt_rad: float = np.radians(20.0), h_m: float = 1.5) -> np.ndarray:
    """T_w_c (4,4) of a camera at (x, 0, h) looking along heading ``yaw_rad``, ``tilt_rad`` down (OpenCV axes)."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    R_yaw = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    R_w_c0 = np.array([[0, 0, 1.0], [-1, 0, 0], [0, -1, 0]])   # z forward (+x), x right (-y), y down
    ct, st = np.cos(tilt_rad), np.sin(tilt_rad)
    return make_T(R_yaw @ R_w_c0 @ np.array([[1, 0, 0], [0, ct, st], [0, -st, ct]]), [x_m, 0, h_m])
