"""Shared machinery of the dataset writers: folder life cycle, streaming CSVs, deterministic files.

Life cycle of an output folder ``out_dir``:

1. :func:`prepare_folder` - a missing or empty folder starts fresh; a folder holding an
   ``INCOMPLETE`` marker is resumed (same configuration) or wiped (``overwrite=True``); a complete
   dataset folder is refused unless ``overwrite=True``. The marker is written before anything else.
2. Frames and samples stream to disk (PNG per image, CSV rows appended and flushed).
3. :func:`finalize_folder` writes ``metadata.yaml`` (atomically, :mod:`rigs.atomic_io`) and removes
   ``INCOMPLETE`` last, so a folder without the marker is always complete.

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

from rigs.atomic_io import atomic_write_bytes, atomic_write_text
from sim.config import PNG_COMPRESSION, PNG_FILTER, PNG_STRATEGY
from sim.errors import SimError
from sim.stage_timer import NO_TIMER

MARKER = "INCOMPLETE"
METADATA = "metadata.yaml"


def fmt_float(v) -> str:
    """Shortest text that round-trips the float64 exactly (Python ``repr``)."""
    return repr(float(v))


def config_hash(metadata: dict) -> str:
    """sha256 of the caller's configuration dict (canonical JSON), used to match a resumed folder."""
    text = json.dumps(metadata, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def write_marker(out_dir: Path, cfg_hash: str, progress: str) -> None:
    """(Re)write the one-line ``INCOMPLETE`` marker: config hash and progress."""
    (out_dir / MARKER).write_text(
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
    entries = list(out_dir.iterdir()) if out_dir.is_dir() else []
    is_ours = (out_dir / MARKER).exists() or (out_dir / METADATA).exists()
    resuming = False
    if entries and not is_ours:
        raise SimError(f"{out_dir}: folder is not empty and holds no dataset (no {METADATA} or {MARKER}); "
                       f"refusing to write into it")
    if entries and overwrite:
        shutil.rmtree(out_dir)
    elif entries and (out_dir / MARKER).exists():
        if marker_hash(out_dir) != h:
            raise SimError(f"{out_dir}: incomplete folder was started with a different configuration; "
                           f"pass --overwrite (overwrite=True) to regenerate it")
        resuming = True
    elif entries:
        raise SimError(f"{out_dir}: a complete dataset is already there; pass --overwrite (overwrite=True) to replace it")
    out_dir.mkdir(parents=True, exist_ok=True)
    write_marker(out_dir, h, "writing started")
    if (out_dir / METADATA).exists():          # stale metadata of a wiped/resumed run
        (out_dir / METADATA).unlink()
    return out_dir, resuming


def finalize_folder(out_dir: Path, metadata: dict, counts: dict, rig) -> None:
    """Write ``metadata.yaml`` (caller config + ``rig`` as rig_to_dict unless the caller gave one +
    counts + ``status: complete``), then drop the marker."""
    from rigs.config_io import dump_yaml
    from rigs.rig_yaml import rig_to_dict
    meta = dict(_plain(metadata))
    if "rig" not in meta:
        meta["rig"] = rig_to_dict(rig)
    meta.update({k: int(v) for k, v in counts.items()})
    meta["status"] = "complete"
    atomic_write_text(out_dir / METADATA, dump_yaml(meta))
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
    """How PNGs are written (``render.png_*``, :class:`sim.config.RenderConfig`): zlib level
    ``compression`` 0-9, zlib ``strategy`` and row ``filter`` (:data:`sim.config.PNG_STRATEGIES`,
    :data:`sim.config.PNG_FILTERS`). The pixels are the same whatever the options."""
    compression: int = PNG_COMPRESSION
    strategy: str = PNG_STRATEGY
    filter: str = PNG_FILTER

    @classmethod
    def of(cls, render) -> "PngOptions":
        """The options of a :class:`sim.config.RenderConfig`."""
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


def write_png(path: Path, image: np.ndarray, rgb: bool = True, png: PngOptions = PngOptions(),
              timer=NO_TIMER) -> None:
    """Write ``image`` as PNG (:func:`encode_png`); deterministic bytes. Written to a temp name then
    renamed, so a file under the final name is always whole. Safe to call from several threads.
    ``timer`` (:class:`sim.stage_timer.StageTimer`) gets the stages ``encode`` and ``write``."""
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
