"""The testbed's one seeding scheme: separate, named, seeded random streams (OpenVINS's simulator:
smooth truth, a random stream per sensor / purpose). Every generator the simulator draws from
comes from here; scenes, textures and the noise steps *receive* their generators.

A stream's generator is ``default_rng(SeedSequence([seed, crc32(name)]))``, and an indexed one
(frame ``k`` of a per-frame stream) ``SeedSequence([seed, crc32(name), k])``: adding a stream never
changes the draws of another. Streams: ``motion`` (vibration), ``imu_white``, ``imu_bias``,
``image_noise`` (indexed by frame), ``wheels``, ``scene`` (static scene layout and textures) and
``dynamic`` (moving actors); the sensor effects (:mod:`sim.sensors.camera`): ``calib_error`` (the
perturbation of the written calibration), ``timestamp_jitter`` and ``sensor_noise`` (shot + read noise,
indexed by frame).

The ``scene`` stream is keyed by a path inside the scene (``<scene>/<purpose>`` for layout,
``texture/<kind>/<variant>`` for textures): :func:`scene_streams` returns the factory a scene
receives, ``key -> default_rng(SeedSequence([seed, crc32(key)]))``. A key must contain ``/``, so
it never coincides with a top-level stream name.
"""
from __future__ import annotations

import zlib
from typing import Callable

import numpy as np

from sim.errors import SimError

STREAMS = ("motion", "imu_white", "imu_bias", "image_noise", "scene", "wheels", "dynamic", "mast",
           "calib_error", "timestamp_jitter", "sensor_noise")

StreamFactory = Callable[[str], np.random.Generator]


def stream(seed: int, name: str) -> np.random.Generator:
    """The generator of stream ``name`` for master ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), _stream_id(name)]))


def indexed_stream(seed: int, name: str, index: int) -> np.random.Generator:
    """A generator for item ``index`` (e.g. a frame) of stream ``name``: draws for frame k do not
    depend on how many frames came before, so resumed or reordered runs give the same bytes."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), _stream_id(name), int(index)]))


def scene_streams(seed: int) -> StreamFactory:
    """The ``scene`` stream's factory for master ``seed``: ``key`` (containing ``/``) -> generator."""
    seed = int(seed)

    def scene_stream(key: str) -> np.random.Generator:
        if "/" not in key:
            raise SimError(f"scene stream key {key!r}: must be a path containing '/' (e.g. 'campus/museum')")
        return np.random.default_rng(np.random.SeedSequence([seed, zlib.crc32(key.encode())]))

    return scene_stream


def _stream_id(name: str) -> int:
    if name not in STREAMS:
        raise SimError(f"random stream {name!r}: unknown; valid: {', '.join(STREAMS)}")
    return zlib.crc32(name.encode())
