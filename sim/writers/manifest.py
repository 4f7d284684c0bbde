"""``manifest.json``: what a complete dataset folder holds, to verify a cached entry before reusing it.

Written by :func:`sim.writers.common.commit_folder` as the last file of every dataset::

    {"version": 1,
     "files": {"<relative path>": {"size": <bytes>, "sha256": "<hex>"}, ...},   # sha256: text files only
     "images": {"count": <n>, "sha256": "<hex of the image list>"}}

Every file has its size; text files (``.csv``, ``.yaml``, ``.txt``, ``.json``) also their SHA-256 (they
are small and hold every number an estimator or the evaluation reads). Images (``.png``, ``.npy``)
are many and large: they are covered by their sizes and by the SHA-256 of the image list (one
``<relative path> <size>`` line per image, sorted), so a missing, added, renamed or truncated image
is found without reading every image. The lock file, the ownership marker, ``INCOMPLETE`` and the
manifest itself are not listed.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from rigs.atomic_io import atomic_write_json, sha256_file

MANIFEST = "manifest.json"
HASHED = (".csv", ".yaml", ".yml", ".txt", ".json")
IMAGES = (".png", ".npy", ".jpg")
SKIP = {MANIFEST, "INCOMPLETE", ".vo-testbed.lock", ".vo-testbed-dataset"}



def _files(folder: Path) -> list:
    """Regular files under ``folder`` (relative POSIX paths, sorted), bookkeeping and temporaries left out."""
    out = []
    for p in folder.rglob("*"):
        rel = p.relative_to(folder).as_posix()
        if p.is_file() and rel not in SKIP and not p.name.startswith(".") and "/." not in f"/{rel}":
            out.append(rel)
    return sorted(out)


def build_manifest(folder) -> dict:
    """The manifest of ``folder`` as it is now (see the module docstring)."""
    folder = Path(folder)
    files, image_lines = {}, []
    for rel in _files(folder):
        p = folder / rel
        size = p.stat().st_size
        entry = {"size": size}
        if p.suffix.lower() in HASHED:
            entry["sha256"] = sha256_file(p)
        files[rel] = entry
        if p.suffix.lower() in IMAGES:
            image_lines.append(f"{rel} {size}")
    image_list = "\n".join(image_lines).encode()
    return {"version": 1, "files": files,
            "images": {"count": len(image_lines), "sha256": hashlib.sha256(image_list).hexdigest()}}


def write_manifest(folder) -> Path:
    """Write ``folder/manifest.json`` (atomically)."""
    return atomic_write_json(Path(folder) / MANIFEST, build_manifest(folder), sort_keys=True)


def verify_manifest(folder) -> list:
    """Problems found in ``folder`` against its manifest, one short phrase each (empty: intact).
    A missing or unreadable manifest is a problem too."""
    folder = Path(folder)
    path = folder / MANIFEST
    try:
        recorded = json.loads(path.read_text())
        files = recorded["files"]
        images = recorded["images"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        return [f"{path}: no readable manifest ({type(e).__name__})"]
    now = build_manifest(folder)
    problems = []
    for rel, entry in files.items():
        got = now["files"].get(rel)
        if got is None:
            problems.append(f"{rel} is missing")
        elif got["size"] != entry.get("size"):
            problems.append(f"{rel} has {got['size']} bytes, the manifest says {entry.get('size')}")
        elif "sha256" in entry and got.get("sha256") != entry["sha256"]:
            problems.append(f"{rel} was modified (SHA-256 differs)")
    if not problems and now["images"] != images:
        problems.append(f"the image list differs ({now['images']['count']} images, the manifest says "
                        f"{images.get('count')})")
    return problems
