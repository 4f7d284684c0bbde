"""Estimator benchmark on named scenarios: accuracy (drift, GCP RMSD, ATE) and ms per frame per stage."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from sim.app.check import scenario_dataset
from vo.dataset import open_dataset
from vo.estimators.runner import CPU_STAGE, run_estimator, wall_and_cpu_ms
from vo.pipeline import evaluate_run, reference_truth


@dataclass
class VoBenchRow:
    scenario: str
    estimator: str
    path_length_m: float
    drift_pct: float
    end_diff_m: float
    gcp_rmsd_m: tuple            # (x, y, z) RMSD at the GCPs, seed 000 Table 4 style
    ate_rmse_m: float
    n_frames: int
    n_lost: int
    n_init: int                  # placeholder frames before the estimator's first pose (frame class "init")
    ms_per_frame: dict = field(default_factory=dict)   # stage -> mean ms (wall clock; "cpu": CPU ms of the calls)

    def to_dict(self) -> dict:
        return asdict(self)


def bench_estimators(scenarios=("campus", "indoor"), estimators=("rop", "klt-pnp", "orb-pnp"),
                     one_core: bool = True, progress: bool = True, max_frames=None, options=None,
                     overrides=()) -> list:
    """Run every estimator on every scenario (datasets cached) -> list of :class:`VoBenchRow`;
    ``options`` (estimator options, as ``--opt``) go to every estimator, ``overrides`` (``key=value``, as
    ``--set``: a held-out ``seed=N``, ``render.supersample=3``) to every scenario."""
    import cv2

    if one_core:
        cv2.setNumThreads(1)
    rows = []
    for scenario in scenarios:
        ds = open_dataset(scenario_dataset(scenario, overrides, progress=progress))
        for name in estimators:
            run = run_estimator(name, ds, options=options or {}, progress=progress, max_frames=max_frames)
            if len(run.estimated()) < 2:              # never initialised: nothing to score, a row of NaN
                rows.append(unevaluated_row(scenario, name, run, ds))
            else:
                rows.append(bench_row(scenario, name, evaluate_run(ds, run, name)))
    return rows


def bench_row(scenario: str, name: str, res) -> VoBenchRow:
    """The row of one ``vo.pipeline.run_and_evaluate`` result."""
    ev = res.evaluation
    rmsd = tuple(float(v) for v in ev.gcps.rmsd_xyz) if ev.gcps is not None else (np.nan,) * 3
    return VoBenchRow(scenario, name, float(ev.drift.gt_length_m), float(ev.drift.drift_ratio_pct),
                      float(ev.drift.end_diff_m), rmsd, float(ev.ape.trans.rmse), len(res.run.frames),
                      int(res.run.n_lost), res.run.class_counts()["init"], dict(res.run.timings_ms))


def unevaluated_row(scenario: str, name: str, run, dataset) -> VoBenchRow:
    """The row of a run with fewer than two estimated poses (classes ok, coasting): figures NaN, the
    route's length from the ground truth, the frames counted."""
    nan = float("nan")
    return VoBenchRow(scenario, name, float(reference_truth(dataset, run).path_length), nan, nan, (nan,) * 3, nan,
                      len(run.frames), int(run.n_lost), run.class_counts()["init"], dict(run.timings_ms))


def format_rows(rows) -> str:
    lines = [f"{'scenario':<17}{'estimator':<10}{'path m':>8}{'drift %':>9}{'RMSD x':>8}{'RMSD y':>8}{'RMSD z':>8}"
             f"{'ATE m':>8}{'lost':>6}{'init':>6}{'ms/frame':>10}{'CPU ms':>8}  stages (ms)"]
    for r in rows:
        total, cpu = wall_and_cpu_ms(r.ms_per_frame)
        stages = " ".join(f"{k} {v:.1f}" for k, v in sorted(r.ms_per_frame.items()) if k not in ("total", CPU_STAGE))
        lines.append(f"{r.scenario:<17}{r.estimator:<10}{r.path_length_m:8.1f}{r.drift_pct:9.2f}"
                     f"{r.gcp_rmsd_m[0]:8.3f}{r.gcp_rmsd_m[1]:8.3f}{r.gcp_rmsd_m[2]:8.3f}{r.ate_rmse_m:8.3f}"
                     f"{r.n_lost:6d}{r.n_init:6d}{total:10.1f}{cpu:8.1f}  {stages}")
    return "\n".join(lines)
