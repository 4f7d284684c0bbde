"""The CI accuracy gate: generate (or reuse) a scenario, run an estimator, compare with bounds.

The gate fails (``passed`` False, exit code 1 in the CLI) when a figure exceeds its bound, the
estimate covers less than ``min_coverage`` of the frames, or the estimator never initialised.
Only poses the estimator produced count (frame classes ok and coasting,
:data:`vo.estimators.base.FRAME_CLASSES`): a placeholder (init: before the estimator has a pose;
lost: the last pose held) is not covered and is not scored by drift, ATE or RPE. Bad input (no
bound, a negative, infinite or NaN bound, an unknown estimator, a program that crashes or writes
garbage) raises a :class:`TestbedError` instead (exit code 2), so a crash never reads as an accuracy
failure. External programs run on a sensor-only view of the dataset (:mod:`vo.estimators.sensor_view`),
with a clean environment, isolated by namespaces where the machine allows it (:mod:`vo.estimators.isolation`),
and are ended after a timeout (:mod:`vo.estimators.external`). In-process estimators get a sensor-only
dataset; an estimator that declares that it reads ground truth (an oracle: ``vins-oracle``, ``--opt
init=truth``) is refused.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

from sim.errors import SimError
from sim.cache_dir import cache_root
from sim.scenarios import cached_dataset, get_scenario
from vo.dataset import open_dataset
from vo.errors import VoError
from vo.estimators.base import PRODUCED_CLASSES
from vo.estimators.external import ExternalCommand
from vo.estimators.isolation import Isolation
from vo.estimators.registry import check_spec, is_external, is_oracle
from vo.estimators.runner import run_estimator
from vo.eval import associate, coverage
from vo.eval.evaluate import status_text
from vo.pipeline import evaluate_run, prepare_out_dir, reference_truth

BOUND_KEYS = {
    "max_drift": ("drift ratio (%)", lambda ev: ev.drift.drift_ratio_pct),
    "max_ate": ("ATE RMSE (m)", lambda ev: ev.ape.trans.rmse),
    "max_rpe": ("RPE per frame, translation RMSE (m)", lambda ev: ev.rpe_frame.trans.rmse),
}
DEFAULT_MIN_COVERAGE = 0.95


@dataclass
class CheckResult:
    scenario: str
    estimator: str
    dataset: str
    figures: dict
    bounds: dict
    coverage: dict
    min_coverage: float
    failures: list = field(default_factory=list)
    n_lost: int = 0
    program_stderr: str = ""
    frames_by_status: dict = field(default_factory=dict)
    isolation: str = "in process"      # an external program's: "namespace" or "view only"

    @property
    def passed(self) -> bool:
        return not self.failures

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "estimator": self.estimator, "dataset": self.dataset,
                "figures": {k: (v if math.isfinite(v) else None) for k, v in self.figures.items()},
                "bounds": self.bounds, "coverage": self.coverage, "min_coverage": self.min_coverage,
                "failures": self.failures, "n_lost": self.n_lost, "frames_by_status": self.frames_by_status,
                "passed": self.passed,
                "program_stderr": self.program_stderr, "isolation": self.isolation}

    def text(self, verbose: bool = False) -> str:
        c = self.coverage
        lines = [f"check {self.estimator} on {self.scenario} ({self.dataset})",
                 f"  {'coverage':<38} {c['n_matched']} of {c['n_reference']} frames "
                 f"({100 * c['fraction']:.1f} %, {c['span_s']:.2f} of {c['reference_span_s']:.2f} s)"
                 f"  (minimum {100 * self.min_coverage:g} %)"]
        failed = {f["bound"] for f in self.failures}
        for key, (label, _) in BOUND_KEYS.items():
            bound = self.bounds.get(key)
            verdict = "" if bound is None else ("  FAIL" if key in failed else
                                                ("  not measured" if math.isnan(self.figures[key]) else "  ok"))
            limit = "" if bound is None else f"  (bound {bound:g})"
            lines.append(f"  {label:<38} {self.figures[key]:10.4f}{limit}{verdict}")
        lines.append(f"  {'frames by status':<38} {status_text(self.frames_by_status)}")
        lines.append(f"  {'isolation':<38} {self.isolation}")
        if self.program_stderr.strip() and (verbose or not self.passed):
            lines += ["  program stderr:"] + [f"    {line}" for line in self.program_stderr.rstrip().splitlines()]
        lines.append("PASSED" if self.passed else "FAILED: " + "; ".join(f["message"] for f in self.failures))
        return "\n".join(lines)


def validate_bounds(bounds: dict, min_coverage: float) -> dict:
    """The given bounds (None dropped); an unknown key, no bound at all, or a bound that is negative,
    infinite or not a number (a bound that can never fail) raises SimError naming the parameter."""
    unknown = set(bounds) - set(BOUND_KEYS)
    if unknown:
        raise SimError(f"unknown bound {sorted(unknown)[0]!r}; valid: {', '.join(BOUND_KEYS)}")
    given = {k: v for k, v in bounds.items() if v is not None}
    if not given:
        raise SimError(f"no bound given: a gate needs at least one of {', '.join(BOUND_KEYS)}")
    for key, value in given.items():
        if not (isinstance(value, (int, float)) and value >= 0):       # negative or NaN
            raise SimError(f"{key}: must be a finite number >= 0, got {value!r}")
        if not math.isfinite(value):
            raise SimError(f"{key}: {value!r} is a bound that can never fail; give a finite number >= 0")
    if not (isinstance(min_coverage, (int, float)) and 0 < min_coverage <= 1):
        raise SimError(f"min_coverage: must be in (0, 1], got {min_coverage!r}")
    return {k: float(v) for k, v in given.items()}


def scenario_dataset(scenario: str, overrides=(), seed: Optional[int] = None, progress: bool = True):
    """The cached dataset folder of ``scenario`` (generated when missing); an unwritable cache
    (``VO_TESTBED_CACHE``) raises SimError naming it."""
    config = get_scenario(scenario, overrides=overrides, seed=seed)
    try:
        return cached_dataset(config, progress=progress)
    except OSError as e:
        raise SimError(f"VO_TESTBED_CACHE={cache_root()}: cannot write the scenario cache "
                       f"({e.strerror or e}{': ' + str(e.filename) if e.filename else ''})") from None


def check(estimator: str, scenario: str, bounds: dict, overrides=(), seed: Optional[int] = None,
          out_dir=None, options: Optional[dict] = None, progress: bool = True,
          min_coverage: float = DEFAULT_MIN_COVERAGE, timeout_s: Optional[float] = None,
          isolation: str = "auto") -> CheckResult:
    """Run ``estimator`` on the cached dataset of ``scenario``; a figure above its bound, fewer than
    ``min_coverage`` of the frames matched by a produced pose, or no produced pose at all, is a failure.
    ``timeout_s`` (None: 20 x the sequence's duration + 60 s) and ``isolation`` ("auto", "required",
    "view-only") apply to a ``cmd:`` program; "required" refuses to run without namespace isolation."""
    bounds = validate_bounds(bounds, min_coverage)
    check_spec(estimator)
    if is_external(estimator):
        ExternalCommand(estimator, timeout_s).check_program()
        Isolation(isolation)                        # "required" where none works: refused before any work
        if timeout_s is not None and not (math.isfinite(timeout_s) and timeout_s > 0):
            raise SimError(f"--timeout: must be a number of seconds > 0, got {timeout_s!r}")
    elif is_oracle(estimator, options):
        raise SimError(f"{estimator}: reads ground truth (an oracle for studies, like vins-oracle or --opt "
                       f"init=truth); a gate cannot judge it")
    if out_dir is not None:
        prepare_out_dir(out_dir)
    path = scenario_dataset(scenario, overrides, seed, progress)
    ds = open_dataset(path)
    run = run_estimator(estimator, ds, options=options or {}, progress=progress, timeout_s=timeout_s,
                        isolation=isolation)
    gt = reference_truth(ds, run)
    cov, ev = _evaluate(ds, run, estimator, gt, out_dir)
    figures = {key: float(fn(ev.evaluation)) if ev else math.nan for key, (_, fn) in BOUND_KEYS.items()}
    counts = run.class_counts()
    failures = _failures(cov, figures if ev is not None else None, bounds, min_coverage, counts, run.name)
    return CheckResult(scenario, estimator, str(path), figures, bounds, cov.to_dict(), min_coverage, failures,
                       run.n_lost, run.stderr, counts, run.isolation or "in process")


def _failures(cov, figures, bounds: dict, min_coverage: float, counts: dict, name: str) -> list:
    """No produced pose (the estimator never initialised), coverage below ``min_coverage`` and every figure
    above its bound; ``figures`` None means fewer than two poses matched (nothing measurable), always a
    failure."""
    def fail(bound, value, limit, message):
        return {"bound": bound, "value": value, "limit": limit, "message": message}
    seen = f"coverage: {cov.n_matched} of {cov.n_reference} frames matched an estimated pose"
    out = []
    if not any(counts[c] for c in PRODUCED_CLASSES):
        out.append(fail("initialised", 0, 1, f"{name} never initialised: none of its {sum(counts.values())} "
                                             f"frames has an estimated pose ({status_text(counts)})"))
    if cov.fraction < min_coverage:
        out.append(fail("min_coverage", cov.fraction, min_coverage,
                        f"{seen} ({100 * cov.fraction:.1f} % < {100 * min_coverage:g} %)"))
    if figures is None:
        return out or [fail("min_coverage", cov.fraction, min_coverage,
                            f"{seen}; at least 2 are needed to measure anything")]
    return out + [fail(k, figures[k], v, f"{BOUND_KEYS[k][0]} {figures[k]:.4f} > {v:g}")
                  for k, v in bounds.items() if not figures[k] <= v]


def _evaluate(ds, run, estimator, gt, out_dir):
    """-> ``(Coverage, Evaluated or None)``; None when fewer than two poses match (nothing to measure)."""
    import numpy as np
    est = run.estimated()                 # placeholders (init, lost) are not covered
    try:
        gt_m, _ = associate(gt, est) if len(est) else (None, None)
    except VoError:                       # not one timestamp matches
        gt_m = None
    gt_m = gt.subset(np.zeros(len(gt), dtype=bool)) if gt_m is None else gt_m
    cov = coverage(gt, est, gt_m)
    if cov.n_matched < 2:
        return cov, None
    return cov, evaluate_run(ds, run, estimator, out_dir=out_dir)
