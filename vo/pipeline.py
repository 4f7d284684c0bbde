"""Run an estimator on a dataset and evaluate it against the dataset's ground truth.

Library functions behind ``vo-testbed run``, ``eval``, ``check`` and the README's main job. The
evaluation policy lives here, not in the CLI: a dataset is opened once; a run is evaluated when
the dataset has ground truth; a run stopped after ``max_frames`` is judged on the frames it was
given, an external program on every frame of the dataset.
"""
from __future__ import annotations

import contextlib

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from rigs.atomic_io import atomic_write_json
from rigs.trajfile import detect_format, kitti_times_path, read_trajectory
from vo.dataset import open_dataset
from vo.dataset.base import read_gcps_csv
from vo.dataset.fisheye_view import for_estimators
from vo.errors import DatasetError, VoError
from vo.estimators.base import FRAME_CLASSES
from vo.estimators.framelog import LOG_NAME, classes_for
from vo.estimators.registry import check_spec
from vo.estimators.runner import run_estimator
from vo.eval import evaluate


@dataclass
class Evaluated:
    """One estimator's run on one dataset with its evaluation."""

    name: str
    run: object          # vo.estimators.runner.RunResult
    evaluation: object   # vo.eval.EvalResult
    est_world: object    # Trajectory T_w_c0 (anchored at the true first pose)

    def to_dict(self) -> dict:
        return {"estimator": self.name, "metrics": self.evaluation.to_dict(),
                "n_frames": len(self.run.frames), "n_lost": self.run.n_lost,
                "frames_by_status": self.run.class_counts(),
                "timings_ms": self.run.timings_ms}


def prepare_out_dir(path) -> Path:
    """Create the output folder ``path`` now, so an unwritable place fails before any work (VoError)."""
    import os
    import tempfile
    out = Path(path).expanduser()
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out, prefix=".write_test_"):
            pass
    except OSError as e:
        raise VoError(f"{out}: cannot write output folder ({e.strerror or e})") from None
    if not os.access(out, os.W_OK):
        raise VoError(f"{out}: cannot write output folder (permission denied)")
    return out


def refuse_dataset_as_out(ds, dataset_dir, out_dir) -> None:
    """A one-line VoError when ``out_dir`` is one of the dataset's own folders (its root, ``mav0``, a KITTI
    sequence): the run's files (``topdown.png``, ``trajectory_*.txt``, ...) would overwrite the dataset's."""
    out = Path(out_dir).expanduser().resolve()
    own = {Path(p).resolve() for p in (dataset_dir, ds.path, getattr(ds, "root", ds.path), getattr(ds, "mav0", ds.path),
                                       getattr(ds, "seq", ds.path))}
    if out in own:
        raise VoError(f"--out {out_dir}: is the dataset's own folder ({dataset_dir}); the run's files (topdown.png, "
                      f"trajectory_tum.txt, ...) would overwrite the dataset's; choose another folder")


def run_dataset(dataset_dir, estimator: str, out_dir, options: Optional[dict] = None, progress: bool = True,
                max_frames=None, seed: int = 0):
    """``vo-testbed run``: open ``dataset_dir`` once, run (OpenCV's RNG seeded with ``seed``), save to
    ``out_dir``, evaluate when the dataset has ground truth and the estimator produced at least two poses
    (classes ok, coasting) -> ``(RunResult, Evaluated or None)``."""
    check_spec(estimator)
    ds = open_dataset(dataset_dir)
    refuse_dataset_as_out(ds, dataset_dir, out_dir)
    ds = for_estimators(ds)            # fisheye cameras: the cv2.fisheye-rectified view
    created = not Path(out_dir).expanduser().exists()
    out = prepare_out_dir(out_dir)
    try:
        run = run_estimator(estimator, ds, options=options or {}, progress=progress, max_frames=max_frames, seed=seed)
    except BaseException:              # a bad option or a failed run: no empty folder left where results would be
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()
        raise
    run.save(out)                      # kept even when the evaluation then fails
    if ds.groundtruth is None or len(run.estimated()) < 2:
        return run, None
    return run, evaluate_run(ds, run, estimator, out_dir=out, save_run=False)


def run_and_evaluate(dataset, estimator: str, out_dir=None, options: Optional[dict] = None,
                     progress: bool = True, align: str = "first", max_frames=None, seed: int = 0) -> Evaluated:
    """Run ``estimator`` on an opened dataset (OpenCV's RNG seeded with ``seed``), evaluate against
    ``dataset.groundtruth_cam0()``."""
    dataset = for_estimators(dataset)  # fisheye cameras: the cv2.fisheye-rectified view
    run = run_estimator(estimator, dataset, options=options or {}, progress=progress, max_frames=max_frames,
                        seed=seed)
    return evaluate_run(dataset, run, estimator, out_dir=out_dir, align=align)


def reference_truth(dataset, run):
    """Ground truth ``T_w_c0`` at the frames the run was given: all of them for an external program,
    the first ``len(run.frames)`` for an in-process run (``max_frames``)."""
    gt = dataset.groundtruth_cam0()
    if gt is None or len(gt) == 0:
        raise VoError(f"{dataset.path}: no ground truth to evaluate against")
    if run.frames and len(run.frames) < len(dataset):
        gt = gt.subset(gt.t_ns <= int(dataset.frame_times_ns[len(run.frames) - 1]))
    return gt


def evaluate_run(dataset, run, estimator: str, out_dir=None, align: str = "first", plots: bool = True,
                 save_run: bool = True) -> Evaluated:
    """Evaluate a finished run against the dataset's ground truth (its produced poses only: classes ok and
    coasting); save (into ``out_dir``) the run's files unless ``save_run`` is False, and the metrics and plots."""
    gt = reference_truth(dataset, run)
    ev = evaluate(gt, run.trajectory, gcps=dataset.gcps, align=align, pose_classes=run.pose_classes())
    label = estimator if not estimator.startswith("cmd:") else "external"
    result = Evaluated(label, run, ev, ev.aligned_est)
    if out_dir is not None:
        out = Path(out_dir)
        if save_run:
            run.save(out)
        atomic_write_json(out / "metrics.json", result.to_dict(), sort_keys=True)
        if plots:
            from vo.eval.plots import plot_error_vs_distance, plot_topdown
            plot_topdown({label: ev.aligned_est}, gt, dataset.gcps, out / "topdown.png")
            plot_error_vs_distance(ev.gt_matched, {label: ev.aligned_est}, out / "error_vs_distance.png")
    return result


def load_gcps(path) -> list:
    """A GCP csv (``#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z``) that must exist and hold rows."""
    if not Path(path).is_file():
        raise DatasetError(f"{path}: GCP file not found")
    gcps = read_gcps_csv(Path(path))
    if not gcps:
        raise DatasetError(f"{path}: no GCP rows (expected #name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z)")
    return gcps


def load_groundtruth(path, fmt: str = "auto"):
    """Ground truth for ``eval``: a trajectory file, or a dataset folder (ours, real EuRoC or KITTI),
    whose left camera ``T_w_c0`` at the frame times is taken (the extrinsics applied to EuRoC's
    IMU/body truth) -> ``(Trajectory, gcps or [], note)``; ``note`` says what was read."""
    if Path(path).is_dir():
        ds = open_dataset(path)
        gt = ds.groundtruth_cam0()
        return gt, list(ds.gcps), f"ground truth: left camera (c0) of the {ds.kind} dataset {ds.path}"
    return read_trajectory(path, fmt), [], ""


def load_estimate(path, fmt: str = "auto", times_path=None, frames_path=None):
    """The estimate for ``eval`` -> ``(Trajectory, pose classes (N,) or None, notes)``. KITTI poses take
    their times from ``times_path`` or the ``times.txt`` beside them (no rate assumed); the classes come
    from the run's frame log ``frames_path`` or the ``frames.csv`` beside ``path`` (None without one: every
    pose counts as ok). ``notes`` say in words what was read."""
    kind = detect_format(path) if fmt == "auto" else fmt
    est = read_trajectory(path, kind, times_path=times_path)
    when = (f", times from {kitti_times_path(path, times_path)}" if kind == "kitti" else "")
    notes = [f"estimate: {path} ({kind}, {len(est)} poses{when})"]
    log = Path(frames_path) if frames_path is not None else Path(path).parent / LOG_NAME
    if frames_path is not None and not log.is_file():
        raise VoError(f"{log}: frame log not found")
    classes = classes_for(est, log) if log.is_file() else None
    if classes is not None:
        counts = ", ".join(f"{c} {int(sum(classes == c))}" for c in FRAME_CLASSES)
        notes.append(f"frame status: {log} ({counts}); init and lost poses are not scored")
    return est, classes, notes

