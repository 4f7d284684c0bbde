"""The per-frame log of a run, ``frames.csv``: written by ``run``, read back by ``eval``.

One row per frame: ``t_ns, status, pose, n_features, n_inliers, message`` and the ms of every stage.
``status`` is the estimator's own word (:data:`~vo.estimators.base.STATUSES`), ``pose`` the class of its
pose (:data:`~vo.estimators.base.FRAME_CLASSES`: ok, coasting, init, lost). With the log, evaluation from
files scores the same poses as evaluation in memory: placeholders (init, lost) are not covered.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from vo.errors import DatasetError
from vo.estimators.base import FRAME_CLASSES, STATUS_CLASS, frame_class
from rigs.trajectory import Trajectory

STAGES = ("detect", "track", "stereo", "pnp", "total")
LOG_NAME = "frames.csv"


def frames_csv(frames: list) -> str:
    """The text of ``frames.csv`` for ``frames`` (FrameResult list); every stage any frame reported."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    extra = sorted({k for f in frames for k in f.timings_ms} - set(STAGES))
    stages = [s for s in STAGES if s != "total"] + extra + ["total"]
    w.writerow(["t_ns", "status", "pose", "n_features", "n_inliers", "message"] + [f"{s}_ms" for s in stages])
    for f in frames:
        w.writerow([f.t_ns, f.status, frame_class(f), f.n_features, f.n_inliers, f.message]
                   + [f"{f.timings_ms.get(s, 0.0):.3f}" for s in stages])
    return buf.getvalue()


def read_frame_classes(path) -> dict:
    """``frames.csv`` -> ``{t_ns: class}``; an empty log (an external program's run) -> ``{}``. A log
    without the ``pose`` column takes the class its ``status`` implies. Bad rows -> DatasetError."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise DatasetError(f"{path}: cannot read the frame log ({e})") from None
    reader = csv.DictReader(io.StringIO(text))
    if reader.fieldnames is None or not {"t_ns", "status"} <= set(reader.fieldnames):
        raise DatasetError(f"{path}: not a frame log (expected the columns t_ns, status[, pose])")
    out = {}
    for n, row in enumerate(reader, 2):
        try:
            t = int(row["t_ns"])
        except (TypeError, ValueError):
            raise DatasetError(f"{path}: line {n}: t_ns must be an integer, got {row['t_ns']!r}") from None
        cls = row.get("pose") or STATUS_CLASS.get(row["status"] or "")
        if cls not in FRAME_CLASSES:
            raise DatasetError(f"{path}: line {n}: unknown status {row['status']!r} / pose {row.get('pose')!r}; "
                               f"valid poses: {', '.join(FRAME_CLASSES)}")
        out[t] = cls
    return out


def classes_for(traj: Trajectory, log_path) -> np.ndarray | None:
    """(N,) class of each pose of ``traj`` from the log ``log_path`` (matched by timestamp); None when the
    log is empty (every pose counts as ok). A pose the log does not list -> DatasetError: the log is
    another run's."""
    classes = read_frame_classes(log_path)
    if not classes:
        return None
    missing = [int(t) for t in traj.t_ns if int(t) not in classes]
    if missing:
        raise DatasetError(f"{log_path}: the frame log has no row for {len(missing)} of the {len(traj)} poses "
                           f"(first t_ns={missing[0]}): it belongs to another run; give the run's own --frames "
                           f"FILE or move it away")
    return np.array([classes[int(t)] for t in traj.t_ns], dtype=object)
