"""Atomic file writing: write to a temporary name in the destination folder, then ``os.replace``.

A reader (or a resumed run) never sees a half-written file under the final name: it finds the old
file, or none, or the whole new one. The temporary name is hidden and unique per process and thread
(``.<name>.<pid>-<thread>.tmp<suffix>``, keeping the suffix so writers that infer the format from the
extension, such as ``cv2.imwrite`` or ``np.save``, still work); it is removed if the write fails.
Parent folders are created. Each function returns the final path.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import threading
from pathlib import Path
from typing import Callable

import numpy as np


def atomic_write(path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp_path)`` to create the file at a temporary name, then rename it to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{threading.get_ident()}.tmp{''.join(path.suffixes[-1:])}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""
    return atomic_write(path, lambda tmp: tmp.write_bytes(data))


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8, newlines as given) to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def json_default(obj):
    """``json.dumps`` fallback: numpy arrays -> lists, numpy scalars -> Python numbers, objects with a
    ``to_dict()`` -> its dict, dataclasses -> dicts, anything else -> ``str``."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if callable(getattr(obj, "to_dict", None)):
        return obj.to_dict()
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return dataclasses.asdict(obj)
    return str(obj)


def atomic_write_json(path, obj, sort_keys: bool = False) -> Path:
    """Write ``obj`` as indented JSON (2 spaces, final newline; :func:`json_default` for numpy values)."""
    return atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=sort_keys, default=json_default) + "\n")


def _to_file(save: Callable) -> Callable[[Path], None]:
    """A ``write(tmp)`` that hands ``save`` an open binary file (numpy then appends no suffix)."""
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            save(f)
    return write


def atomic_write_npz(path, arrays: dict) -> Path:
    """Write ``arrays`` (name -> array) with ``np.savez_compressed`` atomically."""
    return atomic_write(path, _to_file(lambda f: np.savez_compressed(f, **arrays)))


def atomic_write_npy(path, array: np.ndarray) -> Path:
    """Write one array with ``np.save`` (C order) atomically."""
    return atomic_write(path, _to_file(lambda f: np.save(f, np.ascontiguousarray(array))))


def sha256_file(path) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
