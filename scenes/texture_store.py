"""A disk store of procedural textures, so that a scene is drawn once per machine, not once per process.

Drawing a scene's textures (:mod:`scenes.textures`: every large surface has its own pattern and wear)
takes most of the time of building a scene: seconds per process. Every process that renders the same
scene (each ``generate --workers`` process, each test, each run of a sweep) would draw the same bytes
again. :class:`TextureStore` keeps each texture as a ``.npy`` file named by the SHA-256 of everything
that determines its bytes:

- the exact state of the random stream it is drawn from (``bit_generator.state`` of a fresh generator
  of that stream key: the stream's identity, whatever seed and key made it),
- the texture's parameters (kind, richness, size, weathering),
- the source of the drawing code (:data:`_CODE_FILES`: ``scenes/textures.py``, ``scenes/lunar.py``, ``scenes/indoor_walls.py``, the actor
  atlases' modules) and numpy's version,

so a hit gives the very bytes a fresh draw would give. Files are written atomically
(:func:`rigs.atomic_io.atomic_write`), so concurrent processes never see half a texture, and two that draw
the same texture at once write the same bytes. A file that does not load as the expected array (a
damaged cache) is drawn again and replaced.

``TextureStore(None)`` (or ``VO_TESTBED_TEXTURE_CACHE=0`` in :func:`sim.texture_cache.texture_store`)
draws every time and stores nothing.
"""
from __future__ import annotations

import hashlib
import io
from pathlib import Path
from typing import Callable

import numpy as np

from rigs.atomic_io import atomic_write_bytes

_CODE_FILES = ("textures.py", "lunar.py", "builder.py", "actor_textures.py", "actor_sheets.py", "bus_shapes.py",
               "car_shapes.py", "urban_actors.py", "indoor_walls.py", "indoor.py", "indoor_print.py",
               "indoor_fixtures.py")


def _code_digest() -> str:
    h = hashlib.sha256(np.__version__.encode())
    here = Path(__file__).resolve().parent
    for name in _CODE_FILES:
        p = here / name
        h.update(p.read_bytes() if p.exists() else name.encode())
    return h.hexdigest()


class TextureStore:
    """``get(rngs, params, draw)``: the texture ``draw()`` makes, from disk when an identical one was made
    before. ``root``: the folder (made on first write), None: no store."""

    def __init__(self, root: Path | str | None):
        self.root = Path(root) if root is not None else None
        self._code = _code_digest() if root is not None else ""
        self.hits = self.misses = 0

    def key(self, rngs, params: tuple) -> str:
        """SHA-256 hex of the states of the fresh generators ``rngs`` (not advanced), ``params`` and the
        drawing code."""
        h = hashlib.sha256(self._code.encode())
        for rng in rngs:
            h.update(repr(sorted(rng.bit_generator.state.items())).encode())
        h.update(repr(tuple(params)).encode())
        return h.hexdigest()

    def get(self, rngs, params: tuple, draw: Callable[[], np.ndarray]) -> np.ndarray:
        """The ``uint8`` texture ``draw()`` returns; ``rngs``: fresh generators of the streams it draws from
        (in the same state as the ones ``draw`` uses). Read from the store when present."""
        if self.root is None:
            return draw()
        key = self.key(rngs, params)
        path = self.root / key[:2] / f"{key}.npy"
        try:
            img = np.load(path, allow_pickle=False)
            if img.dtype == np.uint8 and img.ndim in (2, 3):
                self.hits += 1
                return img
        except (OSError, ValueError, EOFError):
            pass
        img = draw()
        buf = io.BytesIO()
        np.save(buf, np.ascontiguousarray(img), allow_pickle=False)
        try:
            atomic_write_bytes(path, buf.getvalue())
        except OSError:
            pass                       # a read-only or full cache: the texture is still right, just not kept
        self.misses += 1
        return img
