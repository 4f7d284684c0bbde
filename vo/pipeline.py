"""Run an estimator on a dataset and evaluate it against the dataset's ground truth.

Library functions behind ``vo-testbed run``, ``check`` and the README's main job.
"""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from vo.errors import VoError


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
                "timings_ms": self.run.timings_ms}


def run_and_evaluate(dataset, estimator: str, out_dir=None, options: Optional[dict] = None,
                     progress: bool = True, align: str = "first", max_frames=None) -> Evaluated:
    """Run ``estimator`` on an opened dataset, evaluate against ``dataset.groundtruth_cam0()``."""
    from vo.estimators.registry import is_external
    from vo.estimators.runner import run_estimator

    target = str(dataset.path) if is_external(estimator) else dataset
    run = run_estimator(estimator, target, options=options or {}, progress=progress, max_frames=max_frames)
    return evaluate_run(dataset, run, estimator, out_dir=out_dir, align=align)


def evaluate_run(dataset, run, estimator: str, out_dir=None, align: str = "first", plots: bool = True) -> Evaluated:
    """Evaluate a finished run against the dataset's ground truth; save trajectory, metrics and plots."""
    from vo.eval import evaluate

    gt = dataset.groundtruth_cam0()
    if gt is None or len(gt) == 0:
        raise VoError(f"{dataset.path}: no ground truth to evaluate against")
    ev = evaluate(gt, run.trajectory, gcps=dataset.gcps, align=align)
    label = estimator if not estimator.startswith("cmd:") else "external"
    result = Evaluated(label, run, ev, ev.aligned_est)
    if out_dir is not None:
        out = Path(out_dir)
        run.save(out)
        _write_json(out / "metrics.json", result.to_dict())
        if plots:
            from vo.eval.plots import plot_error_vs_distance, plot_topdown
            plot_topdown({label: ev.aligned_est}, gt, dataset.gcps, out / "topdown.png")
            plot_error_vs_distance(ev.gt_matched, {label: ev.aligned_est}, out / "error_vs_distance.png")
    return result


def _write_json(path: Path, obj) -> None:
    from rigs.io_yaml import write_text_atomic
    write_text_atomic(path, json.dumps(obj, indent=2, sort_keys=True, default=_default))


def _default(o):
    import numpy as np
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if dataclasses.is_dataclass(o):
        return dataclasses.asdict(o)
    return str(o)
