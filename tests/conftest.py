"""Shared fixtures: short rendered sequences generated once per test session."""
import os

import cv2
import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(scope="session")
def campus_short(tmp_path_factory):
    """6 s of the campus route with the cart27 rig (10 Hz, 720x480, lens distortion), seed 0.

    Generated once per session (about 15 s); the cart accelerates from rest to walking speed,
    so the sequence covers start-up (tiny motion) and ~4 m of travel.
    """
    from sim.generate_config import GenerateConfig
    from sim.generate import generate
    out = tmp_path_factory.mktemp("campus_short")
    generate(GenerateConfig(scene="campus", rig="cart27", duration_s=6.0, seed=0), out, progress=False)
    return out


@pytest.fixture(scope="session")
def campus_depth_ideal(tmp_path_factory):
    """4 s of the campus route (cart27), noise-free images with depth, seed 0 (about 10 s to render)."""
    from sim.generate_config import GenerateConfig
    from sim.generate import generate
    out = tmp_path_factory.mktemp("campus_depth")
    generate(GenerateConfig(scene="campus", rig="cart27", duration_s=4.0, seed=0, ideal=True, depth=True), out,
             progress=False)
    return out


def _texture(h=240, w=480, seed=0):
    """A smooth random texture (h,w) uint8 from grey level 20 to 235."""
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 2.0)
    img = cv2.normalize(img, None, 20, 235, cv2.NORM_MINMAX)
    return img.astype(np.uint8)


@pytest.fixture(scope="session")
def shifted():
    """(Synthetic, for the predicted LK starts.) A textured image and the same scene shifted 110 px to the right,
    beyond the 4-level pyramid's reach of a 21-px window; corners away from the borders of both."""
    big = _texture(240, 720)
    img0, img1 = big[:, 200:680].copy(), big[:, 90:570].copy()       # scene point x -> x + 110 in img1
    p0 = cv2.goodFeaturesToTrack(img0, 200, 0.01, 10).reshape(-1, 2).astype(np.float64)
    p0 = p0[(p0[:, 0] > 30) & (p0[:, 0] < 330) & (p0[:, 1] > 20) & (p0[:, 1] < 220)]
    return img0, img1, p0, p0 + [110.0, 0.0]
