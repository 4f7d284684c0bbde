"""Run an estimator over a dataset (reader API) and save its trajectory, per-frame log and summary."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import cv2
import numpy as np

from rigs.atomic_io import atomic_write_json, atomic_write_text as _atomic_write
from vo.errors import EstimatorError, VoError
from vo.estimators.base import FRAME_CLASSES, PRODUCED_CLASSES, STATUSES, FrameResult, frame_class
from vo.estimators.framelog import LOG_NAME, frames_csv
from vo.estimators.progress import progress_iter
from vo.estimators.external import run_external
from vo.estimators.registry import is_external, make_estimator
from vo.estimators.sensor_dataset import SensorDataset
from rigs.trajectory import Trajectory
from rigs.trajfile import write_kitti, write_tum

LOST_STATUSES = ("few_features", "lost")
CPU_STAGE = "cpu"             # the runner's own stage: CPU ms of the estimator's ``process`` call


def wall_and_cpu_ms(timings: dict) -> tuple[float, float]:
    """Mean ms per frame of a run's ``timings_ms`` -> ``(wall clock: the "total" stage, else the sum of the
    estimator's stages; CPU: the runner's ``cpu`` stage, nan without it)``."""
    wall = {k: v for k, v in timings.items() if k != CPU_STAGE}
    return float(wall.get("total", sum(wall.values()))), float(timings.get(CPU_STAGE, float("nan")))


@dataclass
class RunResult:
    """``trajectory`` of ``T_o_c0`` (ref "o", frame "c0"); ``frames`` per-frame results (empty for external
    commands); ``timings_ms`` mean ms per stage over frames (the
    estimator's wall-clock stages, and the runner's ``cpu``: CPU ms of each ``process`` call); ``n_lost`` frames with status few_features/lost.
    Each pose has a class (:data:`~vo.estimators.base.FRAME_CLASSES`); evaluation uses the produced ones
    (:meth:`estimated`), a placeholder (init, lost) counts as not covered."""

    name: str
    trajectory: Trajectory
    frames: list = field(default_factory=list)
    timings_ms: dict = field(default_factory=dict)
    n_lost: int = 0
    wall_time_s: float = 0.0
    stderr: str = ""             # what an external program printed on stderr (its tail)
    isolation: str = ""          # an external program's: "namespace" or "view only"
    estimator: object = None     # the in-process estimator after its last frame (None for external programs)

    @property
    def diagnostics(self) -> list:
        """The estimator's per-frame ``diagnostics`` list (e.g. ``vins``'s feature counts), [] if it keeps none."""
        return list(getattr(self.estimator, "diagnostics", None) or [])

    def pose_classes(self) -> np.ndarray:
        """(N,) class of each trajectory pose; every pose of an external program (no frame log) is ok."""
        if not self.frames:
            return np.full(len(self.trajectory), "ok", dtype=object)
        return np.array([frame_class(f) for f in self.frames], dtype=object)

    def class_counts(self) -> dict:
        """``{"ok": n, "coasting": n, "init": n, "lost": n}`` over the frames."""
        classes = list(self.pose_classes())
        return {c: classes.count(c) for c in FRAME_CLASSES}

    def estimated(self) -> Trajectory:
        """The poses the estimator produced (classes ok and coasting): what evaluation and the gate score."""
        return self.trajectory.subset(np.isin(self.pose_classes(), PRODUCED_CLASSES))

    def summary(self) -> dict:
        counts = {s: 0 for s in STATUSES}
        for f in self.frames:
            counts[f.status] = counts.get(f.status, 0) + 1
        return {"estimator": self.name, "n_frames": len(self.trajectory), "n_lost": self.n_lost,
                "status_counts": counts, "frames_by_status": self.class_counts(),
                "mean_ms": {k: round(v, 3) for k, v in self.timings_ms.items()},
                "wall_time_s": round(self.wall_time_s, 3), "path_length_m": round(self.trajectory.path_length, 4)}

    def save(self, out_dir) -> Path:
        """Write ``trajectory_tum.txt``, ``trajectory_kitti.txt`` (+ ``times.txt``), ``frames.csv``,
        ``summary.json`` into ``out_dir`` (each written to a temporary name, then renamed)."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        write_tum(out / "trajectory_tum.txt", self.trajectory)
        write_kitti(out / "trajectory_kitti.txt", self.trajectory, times_path=out / "times.txt")
        _atomic_write(out / LOG_NAME, frames_csv(self.frames))
        atomic_write_json(out / "summary.json", self.summary())
        return out


def run_estimator(spec: str, dataset, options: dict | None = None, progress: bool = True,
                  max_frames: int | None = None, seed: int = 0, timeout_s: float | None = None,
                  isolation: str = "auto", before_frame: Optional[Callable] = None,
                  on_frame: Optional[Callable] = None, with_truth: bool = False) -> RunResult:
    """Run ``spec`` (name, ``module:Class`` or ``cmd:...``) on ``dataset`` -> :class:`RunResult`.
    ``timeout_s`` and ``isolation`` apply to external programs (:func:`vo.estimators.external.run_external`).

    The one frame loop of the product, its validations and its studies. ``options`` are the estimator's
    constructor keywords, collaborators included (e.g. ``tracker=`` for ``rop``, ``pnp_observer=`` for the
    PnP estimators, ``initializer=`` for ``vins``). Hooks of an in-process run: ``before_frame(frame)`` is
    called before the estimator sees each frame; ``on_frame(frame, result, estimator)`` after it, with the
    checked :class:`FrameResult`, and a true return value ends the run after that frame. The estimator gets
    the whole dataset in ``set_dataset`` when it reads truth (``is_oracle``) or with ``with_truth`` (studies
    and validations that score against truth, e.g. ``vins``'s labelled diagnostics); a sensor-only view
    otherwise. Every frame's result passes the guard (finite 4x4 pose, known status and class).

    OpenCV's global RNG is seeded with ``seed`` before the estimator is made, so a run does not depend on
    what ran before it in the process. Progress: a bar on a terminal, a line per 10 % otherwise."""
    if max_frames is not None and max_frames < 1:
        raise EstimatorError(f"max_frames: must be >= 1, got {max_frames!r}")
    if is_external(spec):
        ext = run_external(spec, dataset, timeout_s, isolation)
        return RunResult(ext.name, ext.trajectory, [], {"total": ext.wall_time_s * 1e3 / max(len(ext.trajectory), 1)},
                         0, ext.wall_time_s, stderr=ext.stderr, isolation=ext.isolation)
    t0 = time.perf_counter()
    cv2.setRNGSeed(int(seed))
    est = make_estimator(spec, dataset.rig, **(options or {}))
    est.set_imu(getattr(dataset, "imu", None))
    est.set_dataset(dataset if with_truth or est.is_oracle(est.options) else SensorDataset(dataset))
    n = len(dataset) if max_frames is None else min(len(dataset), max_frames)
    frames = []
    for frame in progress_iter(dataset.frames(), n, progress, est.name or spec):
        if len(frames) >= n:
            break
        if before_frame is not None:
            before_frame(frame)
        frames.append(_checked(est, frame, frames[-1] if frames else None))
        if on_frame is not None and on_frame(frame, frames[-1], est):
            break
    if not frames:
        raise EstimatorError(f"{spec}: dataset has no frames")
    traj = Trajectory(np.array([f.t_ns for f in frames], np.int64), np.array([f.T_o_c0 for f in frames]), "o", "c0")
    stages = sorted({k for f in frames for k in f.timings_ms})
    timings = {k: float(np.mean([f.timings_ms.get(k, 0.0) for f in frames])) for k in stages}
    n_lost = sum(f.status in LOST_STATUSES for f in frames)
    return RunResult(est.name or spec, traj, frames, timings, n_lost, time.perf_counter() - t0, estimator=est)


def _checked(est, frame, last: FrameResult | None) -> FrameResult:
    """Call ``est.process``; wrap foreign exceptions; enforce a finite 4x4 pose and a known status. The CPU
    time of the call (:func:`time.process_time`: every thread of the process, so a machine shared with other
    jobs does not inflate it as it does the estimator's wall-clock stages) is the frame's ``cpu`` stage (ms)."""
    c0 = time.process_time()
    try:
        res = est.process(frame)
    except VoError:
        raise
    except Exception as e:  # a plug-in's bug: report it with the frame, one line
        raise EstimatorError(f"{est.name or type(est).__name__}: frame {frame.index} (t_ns={frame.t_ns}) "
                             f"raised {type(e).__name__}: {e}") from e
    res.timings_ms = {**(res.timings_ms or {}), CPU_STAGE: (time.process_time() - c0) * 1e3}
    T = np.asarray(res.T_o_c0, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        res.T_o_c0 = last.T_o_c0.copy() if last is not None else np.eye(4)
        res.status, res.message = "lost", f"non-finite pose replaced by the last one; {res.message}"
        res.pose_class = "lost"
    if res.status not in STATUSES:
        raise EstimatorError(f"{est.name}: status {res.status!r} unknown; valid: {', '.join(STATUSES)}")
    if res.pose_class and res.pose_class not in FRAME_CLASSES:
        raise EstimatorError(f"{est.name}: pose_class {res.pose_class!r} unknown; valid: {', '.join(FRAME_CLASSES)}")
    return res
