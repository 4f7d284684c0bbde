"""Shared machinery of the dataset writers: folder life cycle, streaming CSVs, deterministic files.

Life cycle of an output folder ``out_dir``:

0. :func:`claim_folder` (``generate``) - creates ``out_dir``, locks it (:mod:`sim.writers.locking`: a
   second writer gets an error naming the process that holds it), refuses a non-empty folder that does
   not carry our :data:`OWNER` marker, deletes the contents of ours on ``overwrite``, writes the marker.
1. :func:`prepare_folder` - a missing or empty folder starts fresh; a folder holding an
   ``INCOMPLETE`` marker is resumed (same configuration) or wiped (``overwrite=True``); a complete
   dataset folder is refused unless ``overwrite=True``. The marker is written before anything else.
2. Frames and samples stream to disk (PNG per image, CSV rows appended and flushed).
3. :func:`final_metadata` makes the ``metadata.yaml`` content; every other file is written (bags
   included), then :func:`commit_folder` writes ``metadata.yaml`` (``status: complete``, atomically,
   :mod:`rigs.atomic_io`) and ``manifest.json`` (:mod:`sim.writers.manifest`) and removes
   ``INCOMPLETE`` last, so a folder without the marker is always complete and an interrupted one
   always resumes.

No wall-clock time is written anywhere: the same inputs give byte-identical folders.
"""
from __future__ import annotations

import hashlib
import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from rigs.atomic_io import atomic_write, atomic_write_bytes, atomic_write_text
from rigs.config_io import dump_yaml
from rigs.rig_yaml import rig_to_dict
from sim.errors import SimError
from sim.generate_config import PNG_COMPRESSION, PNG_FILTER, PNG_STRATEGY
from sim.stage_timer import NO_TIMER
from sim.writers.locking import LOCK_NAME, FolderLock

MARKER = "INCOMPLETE"
METADATA = "metadata.yaml"
OWNER = ".vo-testbed-dataset"           # our mark: only a folder carrying it is ever deleted (--overwrite)
OWNER_TEXT = "written by vo-testbed generate; `generate --overwrite` may delete this folder\n"
BOOKKEEPING = (LOCK_NAME, OWNER)        # files of ours that do not make a folder "non-empty"


def _entries(out_dir: Path) -> list:
    return [p for p in out_dir.iterdir() if p.name not in BOOKKEEPING] if out_dir.is_dir() else []


def is_owned(out_dir) -> bool:
    """True when ``out_dir`` (or, for ``--format both``'s euroc/ and kitti/, its parent) carries :data:`OWNER`."""
    out_dir = Path(out_dir)
    return (out_dir / OWNER).is_file() or (out_dir.parent / OWNER).is_file()


class ClaimedFolder:
    """The lock on an output folder taken by :func:`claim_folder`; a context manager that releases it,
    and removes the folder again when it created it and a failure left nothing but our bookkeeping."""

    def __init__(self, path: Path, lock: FolderLock, created: bool):
        self.path, self.lock, self.created = path, lock, created

    def __enter__(self) -> "ClaimedFolder":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is not None and self.created and not _entries(self.path):
                shutil.rmtree(self.path, ignore_errors=True)
        finally:
            self.lock.release()


def claim_folder(out_dir, overwrite: bool) -> ClaimedFolder:
    """Create ``out_dir`` and lock it for this process (:class:`sim.writers.locking.FolderBusy`, naming the
    holder's pid, when another process writes it). A non-empty folder without our :data:`OWNER` marker is
    refused (never written into, never deleted); with ``overwrite`` the contents of ours are deleted.
    Every problem is a one-line SimError naming the folder."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise SimError(f"{out_dir}: output path exists and is not a folder")
    created = not out_dir.exists()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        where = f" ({e.filename})" if e.filename and str(e.filename) != str(out_dir) else ""
        raise SimError(f"{out_dir}: cannot create the output folder: {e.strerror or e}{where}") from None
    if _entries(out_dir) and not (out_dir / OWNER).is_file():
        raise SimError(f"{out_dir}: folder is not empty and was not written by vo-testbed (no {OWNER} marker); "
                       f"refusing to {'delete' if overwrite else 'write into'} it")
    lock = FolderLock(out_dir / LOCK_NAME, f"output folder {out_dir}").acquire(wait=False)
    try:
        if overwrite:
            for p in _entries(out_dir):
                shutil.rmtree(p) if p.is_dir() and not p.is_symlink() else p.unlink()
        if not (out_dir / OWNER).is_file():
            (out_dir / OWNER).write_text(OWNER_TEXT)
    except BaseException:
        lock.release()
        raise
    return ClaimedFolder(out_dir, lock, created)


def fmt_float(v) -> str:
    """Shortest text that round-trips the float64 exactly (Python ``repr``)."""
    return repr(float(v))


def config_hash(metadata: dict) -> str:
    """sha256 of the caller's configuration dict (canonical JSON), used to match a resumed folder."""
    text = json.dumps(metadata, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def write_marker(out_dir: Path, cfg_hash: str, progress: str) -> None:
    """(Re)write the one-line ``INCOMPLETE`` marker: config hash and progress. Atomically: an interrupt while it
    is rewritten leaves the old marker, never an empty one that a resumed run would take for another config."""
    atomic_write_text(out_dir / MARKER,
                      f"config={cfg_hash} {progress}; resume by rerunning the same command, or regenerate with overwrite\n")


def marker_hash(out_dir: Path) -> str | None:
    text = (out_dir / MARKER).read_text().split()
    return text[0].partition("=")[2] if text and text[0].startswith("config=") else None


def prepare_folder(out_dir, metadata: dict, overwrite: bool) -> tuple[Path, bool]:
    """Create/validate ``out_dir`` and write the marker; return ``(path, resuming)``.

    Raises SimError for a complete dataset (unless ``overwrite``), a non-empty folder that is not a
    dataset of ours, or an incomplete folder started with a different configuration.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise SimError(f"{out_dir}: output path exists and is not a folder")
    h = config_hash(metadata)
    entries = _entries(out_dir)
    is_ours = (out_dir / MARKER).exists() or (out_dir / METADATA).exists()
    resuming = False
    if entries and not is_ours:
        raise SimError(f"{out_dir}: folder is not empty and holds no dataset (no {METADATA} or {MARKER}); "
                       f"refusing to write into it")
    if entries and overwrite:
        if not is_owned(out_dir):
            raise SimError(f"{out_dir}: not written by vo-testbed (no {OWNER} marker); refusing to delete it")
        for p in entries:
            shutil.rmtree(p) if p.is_dir() and not p.is_symlink() else p.unlink()
    elif entries and (out_dir / MARKER).exists():
        if marker_hash(out_dir) != h:
            raise SimError(f"{out_dir}: incomplete folder was started with a different configuration; "
                           f"pass --overwrite (overwrite=True) to regenerate it")
        resuming = True
    elif entries:
        raise SimError(f"{out_dir}: a complete dataset is already there; pass --overwrite (overwrite=True) to replace it")
    out_dir.mkdir(parents=True, exist_ok=True)
    write_marker(out_dir, h, "writing started")
    if not (out_dir / OWNER).is_file():
        (out_dir / OWNER).write_text(OWNER_TEXT)
    if (out_dir / METADATA).exists():          # stale metadata of a wiped/resumed run
        (out_dir / METADATA).unlink()
    return out_dir, resuming


def final_metadata(metadata: dict, counts: dict, rig) -> dict:
    """``metadata.yaml`` content: caller config + ``rig`` as rig_to_dict unless the caller gave one +
    counts + ``status: complete``."""
    meta = dict(_plain(metadata))
    if "rig" not in meta:
        meta["rig"] = rig_to_dict(rig)
    meta.update({k: int(v) for k, v in counts.items()})
    meta["status"] = "complete"
    return meta


def commit_folder(out_dir: Path, meta: dict) -> None:
    """The last step of a dataset, after every other file: write ``metadata.yaml`` (``meta``), then
    ``manifest.json`` over the whole folder, then drop the ``INCOMPLETE`` marker."""
    from sim.writers.manifest import write_manifest
    atomic_write_text(out_dir / METADATA, dump_yaml(meta))
    write_manifest(out_dir)
    (out_dir / MARKER).unlink()



def _plain(obj):
    """numpy scalars/arrays and tuples -> builtins, so YAML dumps them plainly."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    return obj




_STRATEGY = {"default": cv2.IMWRITE_PNG_STRATEGY_DEFAULT, "filtered": cv2.IMWRITE_PNG_STRATEGY_FILTERED,
             "huffman": cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY, "rle": cv2.IMWRITE_PNG_STRATEGY_RLE,
             "fixed": cv2.IMWRITE_PNG_STRATEGY_FIXED}
_FILTER = {"all": cv2.IMWRITE_PNG_ALL_FILTERS, "fast": cv2.IMWRITE_PNG_FAST_FILTERS,
           "paeth": cv2.IMWRITE_PNG_FILTER_PAETH, "avg": cv2.IMWRITE_PNG_FILTER_AVG, "up": cv2.IMWRITE_PNG_FILTER_UP,
           "sub": cv2.IMWRITE_PNG_FILTER_SUB, "none": cv2.IMWRITE_PNG_FILTER_NONE}


@dataclass(frozen=True)
class PngOptions:
    """How PNGs are written (``render.png_*``, :class:`sim.generate_config.RenderConfig`): zlib level
    ``compression`` 0-9, zlib ``strategy`` and row ``filter`` (:data:`sim.generate_config.PNG_STRATEGIES`,
    :data:`sim.generate_config.PNG_FILTERS`). The pixels are the same whatever the options."""
    compression: int = PNG_COMPRESSION
    strategy: str = PNG_STRATEGY
    filter: str = PNG_FILTER

    @classmethod
    def of(cls, render) -> "PngOptions":
        """The options of a :class:`sim.generate_config.RenderConfig`."""
        return cls(render.png_compression, render.png_strategy, render.png_filter)

    def params(self) -> list:
        return [cv2.IMWRITE_PNG_COMPRESSION, int(self.compression), cv2.IMWRITE_PNG_STRATEGY, _STRATEGY[self.strategy],
                cv2.IMWRITE_PNG_FILTER, _FILTER[self.filter]]


def encode_png(image: np.ndarray, rgb: bool = True, png: PngOptions = PngOptions()) -> bytes:
    """``image`` (H,W) or (H,W,3) RGB (uint8/uint16) as PNG bytes written with ``png``; deterministic (the
    bytes ``cv2.imwrite`` writes with these parameters)."""
    img = np.ascontiguousarray(image)
    if img.ndim == 3 and img.shape[2] == 3 and rgb:
        img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", img, png.params())
    if not ok:
        raise SimError(f"cv2.imencode failed for an image of shape {img.shape} dtype {img.dtype}")
    return buf.tobytes()


@dataclass(frozen=True)
class EncodedPng:
    """An image already encoded by :func:`encode_png` (by a render process, :mod:`sim.render_workers`), with
    the options and ``rgb`` flag of the writer that will write it; :func:`write_png` writes its bytes as they are."""
    data: bytes


def write_png(path: Path, image, rgb: bool = True, png: PngOptions = PngOptions(),
              timer=NO_TIMER) -> None:
    """Write ``image`` (an array, or an :class:`EncodedPng`) as PNG (:func:`encode_png`); deterministic bytes.
    Written to a temp name then renamed, so a file under the final name is always whole. Safe to call from
    several threads. ``timer`` (:class:`sim.stage_timer.StageTimer`) gets the stages ``encode`` and ``write``."""
    if isinstance(image, EncodedPng):
        with timer.stage("write"):
            atomic_write_bytes(path, image.data)
        return
    with timer.stage("encode"):
        data = encode_png(image, rgb, png)
    with timer.stage("write"):
        atomic_write_bytes(path, data)


class CsvStream:
    """An append-only CSV with a header, rows keyed by strictly increasing int64 ``t_ns``.

    On resume the file is cut back to its last whole line (or to ``keep_rows`` data rows), and rows
    at or before the last kept timestamp are skipped silently, so the caller may replay a stream.
    """

    def __init__(self, path: Path, header: str, resuming: bool, keep_rows: int | None = None):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.header = header
        self.rows = 0
        self.last_t: int | None = None
        self.resume_t: int | None = None
        if resuming and self.path.exists():
            self._cut_back(keep_rows)
        else:
            self.path.write_text(header + "\n")
        self._f = open(self.path, "a", encoding="ascii", newline="\n")

    def _cut_back(self, keep_rows: int | None) -> None:
        text = self.path.read_text()
        lines = text.split("\n")[:-1]           # drops "" after a final newline, or a partial last line
        data = [ln for ln in lines[1:] if ln.strip()]
        if keep_rows is not None:
            data = data[:keep_rows]
        self.path.write_text("\n".join([self.header] + data) + "\n")
        self.rows = len(data)
        if data:
            self.last_t = self.resume_t = int(data[-1].split(",")[0])

    def append(self, t_ns: int, fields: list) -> bool:
        """Append one row; returns False when skipped as already written (resume)."""
        t_ns = int(t_ns)
        if self.resume_t is not None and t_ns <= self.resume_t:
            return False
        if self.last_t is not None and t_ns <= self.last_t:
            raise SimError(f"{self.path}: timestamps must increase: {t_ns} after {self.last_t}")
        self._f.write(",".join([str(t_ns)] + [str(x) for x in fields]) + "\n")
        self._f.flush()
        self.last_t = t_ns
        self.rows += 1
        return True

    def close(self) -> None:
        if not self._f.closed:
            self._f.close()
