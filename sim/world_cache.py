"""The machine's world cache: compiled worlds kept under ``$VO_TESTBED_CACHE/worlds/<key>``, so that a
configuration's world is built once per machine, not once per run.

Building a world (:func:`sim.world.build_world`: the scene's geometry and textures, the lens-distortion maps,
MuJoCo's compile) is most of a run's start-up. An entry holds what :mod:`sim.world_handoff` saves (MuJoCo's
binary model, an exact image of ``mjModel``, and the parts it does not hold, the scene's built state included)
plus ``manifest.json`` (the key, and the size and SHA-256 of each file). ``key`` (:func:`world_key`) is the
SHA-256 of everything the world depends on:

- the scene's configuration with its seed resolved (every knob), and, for a scene with moving actors
  (``has_actors``: :func:`scenes.registry.make_scene` hands it the ``dynamic`` stream of the dataset seed),
  the dataset seed; the rig in full (every camera's size, intrinsics, distortion and mounting; the IMU, the
  wheels), the vehicle, whether distortion is rendered;
- the source of every module the build runs (:data:`CODE_TREES`, :data:`CODE_FILES`: ``rigs/``, ``scenes/``,
  ``sim/vehicles/`` and the world's modules; ``tests/test_world_cache.py`` checks that they hold the static
  import closure of the builder), the dataset version, the entry format, and the versions of Python, MuJoCo,
  NumPy, SciPy and OpenCV and the machine's architecture.

A scene given as a plug-in (``"package.module:SceneClass"``, whose code lies outside the package) is never
cached. A hit therefore gives the model a fresh build would give, and the same dataset bytes
(``tests/test_world_cache.py``).

Safety: an entry is written into a hidden staging folder and renamed into place (a reader sees a whole entry
or none), under a lock (:class:`sim.writers.locking.FolderLock`) that also lets one of two processes that
built the same world at once keep the entry there. A reader first hard-links the entry's files into a private
folder (:meth:`WorldCache.checkout`), then checks sizes and SHA-256 against the manifest: an entry that a
later writer replaces or evicts meanwhile cannot change under it, and a damaged or partial entry is a miss,
rebuilt and replaced. Entries are evicted, least recently used first, beyond ``VO_TESTBED_WORLD_CACHE_MB``
(default :data:`DEFAULT_LIMIT_MB`). ``VO_TESTBED_WORLD_CACHE=0`` turns the cache off (as
``VO_TESTBED_TEXTURE_CACHE=0`` the texture store); a cache that cannot be written is skipped silently.
"""
from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import json
import os
import platform
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Optional

import numpy as np

from rigs.atomic_io import sha256_file
from sim.cache_dir import cache_root
from sim.errors import SimError
from sim.version import __version__
from sim.world import World, build_world
from sim.world_handoff import MODEL_FILE, PARTS_FILE, WorldFiles, load_world, save_world
from sim.writers.locking import FolderLock

ENTRY_FORMAT = 1                    # the layout of an entry (bump when it changes)
MANIFEST = "manifest.json"
ENTRY_FILES = (MODEL_FILE, PARTS_FILE)
DEFAULT_LIMIT_MB = 4096
STALE_S = 86400.0                   # hidden folders of killed processes older than this are removed
CODE_TREES = ("rigs", "scenes", "sim/vehicles")
CODE_FILES = ("sim/__init__.py", "sim/cache_dir.py", "sim/distortion.py", "sim/errors.py", "sim/mjcam.py",
              "sim/rng.py", "sim/texture_cache.py", "sim/version.py", "sim/world.py", "sim/world_handoff.py",
              "sim/world_cache.py")
_OFF = ("0", "off", "false", "no")


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 hex of the builder's source files (:data:`CODE_TREES`, :data:`CODE_FILES`) and the versions it
    runs with; computed once per process."""
    import cv2
    import mujoco
    import scipy
    root = Path(__file__).resolve().parents[1]
    paths = sorted({p for t in CODE_TREES for p in (root / t).rglob("*.py")} | {root / f for f in CODE_FILES})
    h = hashlib.sha256(json.dumps([ENTRY_FORMAT, __version__, sys.version_info[:3], platform.machine(),
                                   mujoco.__version__, np.__version__, scipy.__version__, cv2.__version__]).encode())
    for p in paths:
        h.update(str(p.relative_to(root)).encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def _canonical(obj):
    """``obj`` as JSON-able builtins that tell apart any two unequal values (floats exactly, arrays by dtype,
    shape and bytes, dataclasses by type and every field)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return [type(obj).__qualname__, {f.name: _canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)}]
    if isinstance(obj, dict):
        return [[_canonical(k), _canonical(v)] for k, v in sorted(obj.items(), key=lambda kv: repr(kv[0]))]
    if isinstance(obj, (list, tuple)):
        return [_canonical(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return ["ndarray", obj.dtype.str, list(obj.shape), hashlib.sha256(np.ascontiguousarray(obj)).hexdigest()]
    if isinstance(obj, enum.Enum):
        return _canonical(obj.value)
    if isinstance(obj, np.generic):
        return obj.item()
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    return [type(obj).__qualname__, repr(obj)]


def world_key(config, rig, vehicle: str, distort: bool = True) -> Optional[str]:
    """The cache key of the world :func:`sim.world.build_world` makes for ``config``'s scene (as
    :func:`sim.generate.resolve` makes it), ``rig`` and ``vehicle``: SHA-256 hex (module docstring); None for a
    plug-in scene (not cached)."""
    from scenes.registry import SCENES
    scene = config.scene_config
    if scene.name not in SCENES:
        return None
    actors = bool(getattr(SCENES[scene.name], "has_actors", False))
    blob = {"scene": _canonical(scene), "dynamic_seed": config.seed if actors else None, "rig": _canonical(rig),
            "vehicle": vehicle, "distort": bool(distort), "code": code_digest()}
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()


def write_manifest(folder, key: str) -> None:
    """``manifest.json`` of the world files in ``folder`` (the key, each file's size and SHA-256)."""
    folder = Path(folder)
    files = {n: [(folder / n).stat().st_size, sha256_file(folder / n)] for n in ENTRY_FILES}
    (folder / MANIFEST).write_text(json.dumps({"format": ENTRY_FORMAT, "key": key, "files": files}))


def verify(folder, key: str) -> bool:
    """Whether ``folder`` holds a whole, undamaged entry of ``key`` (manifest, sizes, SHA-256)."""
    folder = Path(folder)
    try:
        m = json.loads((folder / MANIFEST).read_text())
        if m.get("format") != ENTRY_FORMAT or m.get("key") != key or sorted(m["files"]) != sorted(ENTRY_FILES):
            return False
        return all((folder / n).stat().st_size == size and sha256_file(folder / n) == sha
                   for n, (size, sha) in m["files"].items())
    except (OSError, ValueError, KeyError, TypeError):
        return False


def _link_or_copy(src: Path, dst: Path) -> None:
    try:
        os.link(src, dst)
    except FileNotFoundError:
        raise
    except OSError:                           # a file system without hard links
        shutil.copyfile(src, dst)


class WorldCache:
    """Compiled worlds under ``root`` (None: a cache that keeps nothing); ``limit_mb``: the size beyond which
    the least recently used entries are evicted."""

    def __init__(self, root, limit_mb: float = DEFAULT_LIMIT_MB):
        self.root = Path(root) if root is not None else None
        self.limit_bytes = float(limit_mb) * 2 ** 20

    def scratch(self, prefix: str) -> Path:
        """A new private folder: hidden in the cache (same file system as its entries), else the system's."""
        if self.root is not None:
            try:
                self.root.mkdir(parents=True, exist_ok=True)
                return Path(tempfile.mkdtemp(prefix=f".{prefix}-", dir=self.root))
            except OSError:
                pass
        return Path(tempfile.mkdtemp(prefix=f"vo-testbed-{prefix}-"))

    def checkout(self, key: Optional[str]) -> Optional[Path]:
        """A private folder holding entry ``key``'s files (hard links: immune to a later replacement or
        eviction), checked against its manifest; None on a miss or a damaged entry. The caller removes it."""
        if self.root is None or key is None or not (self.root / key).is_dir():
            return None
        folder = self.scratch("checkout")
        try:
            for name in ENTRY_FILES + (MANIFEST,):
                _link_or_copy(self.root / key / name, folder / name)
            if verify(folder, key):
                try:
                    os.utime(self.root / key)     # recently used (eviction order)
                except OSError:
                    pass                          # replaced or evicted meanwhile: the checkout holds its files
                return folder
        except OSError:
            pass
        shutil.rmtree(folder, ignore_errors=True)
        return None

    def publish(self, key: Optional[str], folder, own: bool = False) -> bool:
        """Put the world files saved in ``folder`` in the cache as entry ``key`` (``own``: the folder is this
        process's to move, else its files are linked); an entry already there and whole is kept. Whether the
        entry is there afterwards; never raises for the cache's sake."""
        if self.root is None or key is None:
            return False
        stage = None
        try:
            if own:
                stage = Path(folder)
            else:
                stage = self.scratch("stage")
                for name in ENTRY_FILES:
                    _link_or_copy(Path(folder) / name, stage / name)
            write_manifest(stage, key)
            os.chmod(stage, 0o755)                # mkdtemp's 0700: an entry is readable as the cache is
            entry = self.root / key
            with FolderLock(self.root / ".lock", f"world cache {self.root}").acquire(wait=True):
                if entry.exists() and verify(entry, key):
                    return True
                if entry.exists():                # damaged: moved aside, then replaced
                    trash = self.root / f".trash-{key}-{os.getpid()}-{threading.get_ident()}"
                    os.rename(entry, trash)
                    shutil.rmtree(trash, ignore_errors=True)
                os.rename(stage, entry)
                stage = None
                self._evict(keep=key)
            return True
        except (OSError, SimError):
            return False
        finally:
            if stage is not None:
                shutil.rmtree(stage, ignore_errors=True)

    def _evict(self, keep: str) -> None:
        """Remove least recently used entries beyond the size limit (never ``keep``), and hidden folders of
        processes killed more than :data:`STALE_S` ago. Called under the cache's lock."""
        now, entries = time.time(), []
        for p in self.root.iterdir():
            try:
                if p.name.startswith(".") and p.is_dir() and now - p.stat().st_mtime > STALE_S:
                    shutil.rmtree(p, ignore_errors=True)
                elif not p.name.startswith(".") and p.is_dir():
                    entries.append((p.stat().st_mtime, sum(f.stat().st_size for f in p.iterdir()), p))
            except OSError:
                continue
        total = sum(size for _, size, _ in entries)
        for _, size, p in sorted(entries, key=lambda e: e[0]):
            if total <= self.limit_bytes:
                break
            if p.name != keep:
                shutil.rmtree(p, ignore_errors=True)
                total -= size

    def world(self, config, scene, rig, vehicle: str) -> tuple:
        """``(world, source)``: the :class:`sim.world.World` of ``config``'s ``scene`` with ``rig`` on
        ``vehicle``, loaded from the cache (``source`` ``"hit"``) or built (``"miss"``, then stored; ``"off"``
        without a cache or for a plug-in scene)."""
        key = world_key(config, rig, vehicle) if self.root is not None else None
        folder = self.checkout(key)
        if folder is not None:
            try:
                return load_world(WorldFiles(str(folder), key), scene, rig), "hit"
            except SimError:
                pass                              # not loadable here: built again below
            finally:
                shutil.rmtree(folder, ignore_errors=True)
        world = build_world(scene, rig, vehicle=vehicle)
        if key is None:
            return world, "off"
        stage = self.scratch("stage")
        try:
            save_world(world, stage, key)
        except (OSError, ValueError):
            shutil.rmtree(stage, ignore_errors=True)
            return world, "miss"
        self.publish(key, stage, own=True)
        return world, "miss"


def world_cache() -> WorldCache:
    """The cache under ``$VO_TESTBED_CACHE/worlds``, or one that keeps nothing when ``VO_TESTBED_WORLD_CACHE=0``."""
    if os.environ.get("VO_TESTBED_WORLD_CACHE", "1").strip().lower() in _OFF:
        return WorldCache(None)
    text = os.environ.get("VO_TESTBED_WORLD_CACHE_MB", str(DEFAULT_LIMIT_MB))
    try:
        limit = float(text)
    except ValueError:
        limit = float("nan")
    if not 0 <= limit < float("inf"):
        raise SimError(f"VO_TESTBED_WORLD_CACHE_MB: expected a number of megabytes >= 0, got {text!r}")
    return WorldCache(cache_root() / "worlds", limit)


class WorldHandoff:
    """The world of one :class:`sim.render_workers.ChunkSource` run, for its worker processes: a checkout of the
    cached entry (``hit``: the workers load it at once, without waiting for this process) or a folder that the
    world built here is saved into (:meth:`world`), then stored in the cache beside the run (:meth:`publish`).
    ``files`` (:class:`sim.world_handoff.WorldFiles`) tell the workers where it is; ``ready`` (an event the workers
    wait on) is set on a hit. Use :meth:`close` at the end."""

    def __init__(self, config, ready=None, cache: Optional[WorldCache] = None):
        self.cache = cache if cache is not None else world_cache()
        self.key = world_key(config, config.rig, config.vehicle) if self.cache.root is not None else None
        self.folder = self.cache.checkout(self.key)
        self.hit = self.folder is not None
        if self.hit and ready is not None:
            ready.set()                            # the workers' event: nothing to wait for
        elif not self.hit:
            self.folder = self.cache.scratch("handoff")
        self.files = WorldFiles(str(self.folder), config.config_hash())
        self._publisher: Optional[threading.Thread] = None

    @property
    def source(self) -> str:
        """``"hit"`` (from the cache), ``"miss"`` (built here, then cached) or ``"off"`` (no cache, or a plug-in)."""
        return "hit" if self.hit else ("miss" if self.key is not None else "off")

    def world(self, setup, vehicle: str) -> World:
        """This process's world of ``setup`` (scene, rig as the config's): loaded on a hit, else built and saved."""
        if self.hit:
            return load_world(self.files, setup.scene, setup.rig)
        world = build_world(setup.scene, setup.rig, vehicle=vehicle)
        save_world(world, self.folder, self.files.key)
        return world

    def publish(self) -> None:
        """Store the world saved here in the cache, on a thread (hashing it is off the render's path)."""
        if not self.hit and self.key is not None and (self.folder / MODEL_FILE).exists():
            self._publisher = threading.Thread(target=self.cache.publish, args=(self.key, self.folder),
                                               name="world-cache-publish", daemon=True)
            self._publisher.start()

    def close(self) -> None:
        if self._publisher is not None:
            self._publisher.join()
        shutil.rmtree(self.folder, ignore_errors=True)
