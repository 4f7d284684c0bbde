"""The code fingerprint of a sweep cell: a digest of the source that produces a cell's numbers.

A cell's key hashes its configuration, not the code that ran it. Each record therefore carries
``code``, the fingerprint of the worker that ran it, so that a resumed sweep can tell records made by
other code (stale) from current ones instead of silently mixing code versions.

The fingerprint is the sha256 (first 16 hex characters) over the relative path and bytes of every
``*.py`` file of :data:`PACKAGES` (``rigs``, ``scenes``, ``sim``, ``vo``), in sorted path order. The
app layer ``sim/app`` is left out (its CLI, plots and reports do not change a record's numbers), except
``sim/app/sweep/cell.py``, which runs the cell. Packages are located through the import system (the
package's ``__init__.py`` and search path, as ``__file__`` gives them), without importing them, so an
editable install and an installed wheel give the same digest for the same source. It is computed
once per process (about 1 MB of source, a few milliseconds).
"""
from __future__ import annotations

import functools
import hashlib
import importlib.util
from pathlib import Path

PACKAGES = ("rigs", "scenes", "sim", "vo")
EXCLUDED = ("sim/app",)                        # relative folders left out ...
INCLUDED = ("sim/app/sweep/cell.py",)          # ... except these files
DIGEST_CHARS = 16


def source_files(packages=None, excluded=None, included=None) -> list:
    """``[(relative posix path, Path), ...]`` of the fingerprinted sources, sorted by relative path
    (defaults: :data:`PACKAGES`, :data:`EXCLUDED`, :data:`INCLUDED`)."""
    packages = PACKAGES if packages is None else packages
    excluded = EXCLUDED if excluded is None else excluded
    included = INCLUDED if included is None else included
    files = {}
    for name in packages:
        for root in _package_dirs(name):
            for path in root.rglob("*.py"):
                rel = (Path(name) / path.relative_to(root)).as_posix()
                if rel in included or not any(rel.startswith(ex.rstrip("/") + "/") for ex in excluded):
                    files.setdefault(rel, path)
    return sorted(files.items())


def fingerprint_files(files) -> str:
    """The digest of ``[(relative path, Path), ...]``: path and length-prefixed bytes of each file."""
    h = hashlib.sha256()
    for rel, path in files:
        data = Path(path).read_bytes()
        h.update(rel.encode() + b"\0" + str(len(data)).encode() + b"\0")
        h.update(data)
    return h.hexdigest()[:DIGEST_CHARS]


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """The fingerprint of the code of this process (cached: computed once per process)."""
    return fingerprint_files(source_files())


def _package_dirs(name: str) -> list:
    """The folders of top-level package ``name`` (its ``__file__``'s folder; several for a namespace package)."""
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError(f"code fingerprint: {name!r} is not an importable package")
    return [Path(p).resolve() for p in spec.submodule_search_locations]
