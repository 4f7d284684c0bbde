"""Synthetic stereo pairs with exact truth for the front-end tests: a rectified pinhole rig, a random
texture and an exact band-limited sub-pixel shift."""
import cv2
import numpy as np
from scipy.ndimage import fourier_shift

from rigs.geometry import make_T
from rigs.model import Camera, Rig

R_B_C = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]])


def texture(seed, h=240, w=320, lo=20, hi=235, blur=2.0):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.random((h, w)), (0, 0), blur)
    return lo + (hi - lo) * (t - t.min()) / (t.max() - t.min())


def shifted(img_f, du, dv):
    """Exact (band-limited, periodic) sub-pixel shift: out(x + du, y + dv) = img(x, y)."""
    return np.real(np.fft.ifft2(fourier_shift(np.fft.fft2(img_f), (dv, du))))


def grid_points(h, w, step=40, margin=40):
    return np.array([[u, v] for v in range(margin, h - margin + 1, step) for u in range(margin, w - margin + 1, step)], float)


def stereo_rig(width=320, height=240):
    """Rectified pinhole pair, baseline 0.2 m along +x of c0: epipolar lines are image rows."""
    cams = tuple(Camera(n, width, height, 300, 300, (width - 1) / 2, (height - 1) / 2, T_b_c=make_T(R_B_C, [0, y, 1]))
                 for n, y in (("cam0", 0.1), ("cam1", -0.1)))
    return Rig("test", cams)
