"""One sweep cell on a worker: generate its dataset, run every estimator, write its record atomically.

The record ``DIR/cells/<key>.json`` is written last and in one rename (:mod:`rigs.atomic_io`), so
its presence means the cell is done: a resumed sweep skips it, and a cell cut short leaves no
record (its half-generated dataset under ``DIR/work/<key>`` is resumed by :func:`sim.generate.generate`).
The dataset is deleted after the run unless ``keep_datasets`` (then it stays in ``DIR/datasets/<key>``).
A failure (generation or one estimator) is recorded with its message instead of stopping the sweep.
The record's ``code`` is the worker's :func:`~sim.app.sweep.fingerprint.code_fingerprint`: the code
that actually ran the cell; a record made by other code is stale (:func:`is_stale`).

Each cell is a pure function of its configuration: the dataset draws from the config's seed, and
OpenCV's RANSAC generator (thread-local, otherwise carried from cell to cell on a long-lived worker)
is re-seeded from the cell's seed before each estimator, so a result does not depend on which worker
ran the cell or what it ran before.
"""
from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

from rigs.atomic_io import atomic_write_json
from sim.app.sweep.fingerprint import code_fingerprint
from sim.generate import generate
from vo.dataset import open_dataset
from vo.estimators.runner import wall_and_cpu_ms
from vo.pipeline import run_and_evaluate

RECORD_VERSION = 1


def record_path(out_dir, key: str) -> Path:
    return Path(out_dir) / "cells" / f"{key}.json"


def read_record(out_dir, key: str):
    """The finished record of cell ``key``, or None (absent or unreadable: the cell runs again)."""
    path = record_path(out_dir, key)
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return rec if rec.get("version") == RECORD_VERSION else None


def is_stale(record, code: str) -> bool:
    """Whether ``record`` was made by code other than ``code`` (a record without ``code`` is stale)."""
    return record.get("code") != code


def is_done(record, estimators, retry_failed: bool = False, code=None) -> bool:
    """Whether ``record`` covers every estimator (and, with ``retry_failed``, none failed); given
    ``code`` (a fingerprint), a record made by other code is not done."""
    if record is None or (code is not None and is_stale(record, code)):
        return False
    runs = record.get("runs", {})
    if record.get("error"):                   # the cell itself failed (generation, a crashed worker)
        return not retry_failed
    if any(name not in runs for name in estimators):
        return False
    return not (retry_failed and any(r.get("error") for r in runs.values()))


def run_cell(cell, estimators, out_dir, keep_datasets: bool = False) -> dict:
    """Generate ``cell``'s dataset, run ``estimators``, write and return its record (never raises
    for a failing generation or estimator: the error is recorded)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    import cv2
    cv2.setNumThreads(1)
    out_dir = Path(out_dir)
    t0 = time.perf_counter()
    record = {"version": RECORD_VERSION, "key": cell.key, "code": code_fingerprint(), "seed": cell.seed,
              "values": dict(cell.values),
              "baseline_m": float(cell.config.rig.baseline), "fx_px": float(cell.config.rig.cameras[0].fx),
              "error": None, "runs": {}}
    data_dir = out_dir / ("datasets" if keep_datasets else "work") / cell.key
    try:
        dataset = _generate(cell.config, data_dir)
        record["generate_s"] = round(time.perf_counter() - t0, 3)
        for name in estimators:
            record["runs"][name] = _run_one(dataset, name, cell.seed)
    except Exception as exc:      # noqa: BLE001 - a failed cell is recorded, the sweep goes on
        record["error"] = _message(exc)
    finally:
        if not keep_datasets:
            shutil.rmtree(data_dir, ignore_errors=True)
    record.update(wall_s=round(time.perf_counter() - t0, 3), rss_mb=_rss_mb(), pid=os.getpid(),
                  finished_unix_s=round(time.time(), 3))
    atomic_write_json(record_path(out_dir, cell.key), record, sort_keys=True)
    return record


def _generate(config, data_dir: Path):
    if not ((data_dir / "metadata.yaml").exists() and not (data_dir / "INCOMPLETE").exists()):
        generate(config, data_dir, progress=False, overwrite=False)
    return open_dataset(data_dir)


def _run_one(dataset, name: str, seed: int) -> dict:
    """Run and evaluate one estimator -> its metrics, or ``{"error": ...}``."""
    t0 = time.perf_counter()
    try:
        res = run_and_evaluate(dataset, name, progress=False, seed=seed)      # seeds OpenCV's RNG
    except Exception as exc:      # noqa: BLE001 - recorded in the table
        return {"error": _message(exc), "wall_s": round(time.perf_counter() - t0, 3)}
    ev, run = res.evaluation, res.run
    wall_ms, cpu_ms = wall_and_cpu_ms(run.timings_ms)
    return {"error": None, "drift_pct": float(ev.drift.drift_ratio_pct), "end_diff_m": float(ev.drift.end_diff_m),
            "path_length_m": float(ev.drift.gt_length_m), "ate_rmse_m": float(ev.ape.trans.rmse),
            "rpe_trans_rmse_m": float(ev.rpe_frame.trans.rmse), "rpe_rot_rmse_deg": float(ev.rpe_frame.rot_deg.rmse),
            "n_frames": len(run.frames), "n_lost": int(run.n_lost),
            "ms_per_frame": wall_ms, "cpu_ms_per_frame": cpu_ms,
            "wall_s": round(time.perf_counter() - t0, 3)}


def _message(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}".splitlines()[0]


def _rss_mb() -> float:
    """Resident memory of this (worker) process in MiB."""
    try:
        import psutil
        return round(psutil.Process().memory_info().rss / 2 ** 20, 1)
    except ImportError:
        import resource
        return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
