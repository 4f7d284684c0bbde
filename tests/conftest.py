"""Shared fixtures: short rendered sequences generated once per test session."""
import os

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
