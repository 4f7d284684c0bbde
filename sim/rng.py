"""Separate, named, seeded random streams (one per sensor / purpose), as OpenVINS's simulator does.

Adding a new stream never changes the draws of an existing one: each stream's
generator is seeded from ``(seed, crc32(name))``.
"""
from __future__ import annotations

import zlib

import numpy as np

STREAMS = ("motion", "imu_white", "imu_bias", "image_noise", "scene", "wheels", "dynamic")


def stream(seed: int, name: str) -> np.random.Generator:
    """The generator of stream ``name`` for master ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), _stream_id(name)]))


def indexed_stream(seed: int, name: str, index: int) -> np.random.Generator:
    """A generator for item ``index`` (e.g. a frame) of stream ``name``: draws for frame k do not
    depend on how many frames came before, so resumed or reordered runs give the same bytes."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), _stream_id(name), int(index)]))


def _stream_id(name: str) -> int:
    if name not in STREAMS:
        raise ValueError(f"unknown random stream {name!r}; valid: {', '.join(STREAMS)}")
    return zlib.crc32(name.encode())
