"""Monte-Carlo consistency of an estimator's covariance (OpenVINS ov_eval style): render once, re-noise per run.

:mod:`.runs` runs the estimator on ``R`` noise realisations (:class:`.runs.NoisyDataset`, a process
pool), :mod:`.scoring` turns the runs into NEES and predicted-vs-measured spread
(:class:`.scoring.ConsistencyResult`), :mod:`.plots` draws them and :mod:`.io` writes the output folder.
``vo-testbed consistency`` is :func:`consistency` then :func:`write_outputs`; docs/consistency.md.
"""
from sim.app.nees.io import write_outputs
from sim.app.nees.plots import plot_consistency
from sim.app.nees.runs import VARY, NoisyDataset, consistency
from sim.app.nees.scoring import (MIN_DISTANCE_M, ConsistencyResult, end_errors, evaluate_runs, pose_errors,
                                         truth_per_run)

__all__ = ["VARY", "MIN_DISTANCE_M", "NoisyDataset", "ConsistencyResult", "consistency", "evaluate_runs",
           "end_errors", "pose_errors", "truth_per_run", "plot_consistency", "write_outputs"]
