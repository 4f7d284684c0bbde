"""The machine's texture store: scenes' procedural textures kept under ``$VO_TESTBED_CACHE/textures``.

Every process that builds a scene (:func:`sim.world.build_world`) reads the textures it has drawn before
from here instead of drawing them again (:class:`scenes.texture_store.TextureStore`: files named by the
SHA-256 of the stream state, parameters and drawing code, written atomically). A hit gives the same
bytes as a fresh draw, so datasets do not depend on the store. ``VO_TESTBED_TEXTURE_CACHE=0`` turns it off.
"""
from __future__ import annotations

import os

from scenes.texture_store import TextureStore
from sim.cache_dir import cache_root


def texture_store() -> TextureStore:
    """The store under the cache root, or one that keeps nothing when ``VO_TESTBED_TEXTURE_CACHE=0``."""
    if os.environ.get("VO_TESTBED_TEXTURE_CACHE", "1").strip().lower() in ("0", "off", "false", "no"):
        return TextureStore(None)
    return TextureStore(cache_root() / "textures")
