"""The CI accuracy gate: generate (or reuse) a scenario, run an estimator, compare with bounds."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from sim.errors import SimError

BOUND_KEYS = {
    "max_drift": ("drift ratio (%)", lambda ev: ev.drift.drift_ratio_pct),
    "max_ate": ("ATE RMSE (m)", lambda ev: ev.ape.trans.rmse),
    "max_rpe": ("RPE per frame, translation RMSE (m)", lambda ev: ev.rpe_frame.trans.rmse),
}


@dataclass
class CheckResult:
    scenario: str
    estimator: str
    dataset: str
    figures: dict
    bounds: dict
    failures: list = field(default_factory=list)
    n_lost: int = 0

    @property
    def passed(self) -> bool:
        return not self.failures

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "estimator": self.estimator, "dataset": self.dataset,
                "figures": self.figures, "bounds": self.bounds, "failures": self.failures,
                "n_lost": self.n_lost, "passed": self.passed}

    def text(self) -> str:
        lines = [f"check {self.estimator} on {self.scenario} ({self.dataset})"]
        for key, (label, _) in BOUND_KEYS.items():
            bound = self.bounds.get(key)
            verdict = "" if bound is None else ("  FAIL" if key in {f['bound'] for f in self.failures} else "  ok")
            limit = "" if bound is None else f"  (bound {bound:g})"
            lines.append(f"  {label:<38} {self.figures[key]:10.4f}{limit}{verdict}")
        lines.append(f"  frames lost: {self.n_lost}")
        lines.append("PASSED" if self.passed else "FAILED: " + "; ".join(f["message"] for f in self.failures))
        return "\n".join(lines)


def check(estimator: str, scenario: str, bounds: dict, overrides=(), seed: Optional[int] = None,
          out_dir=None, options: Optional[dict] = None, progress: bool = True) -> CheckResult:
    """Run ``estimator`` on the cached dataset of ``scenario``; a figure above its bound is a failure."""
    from sim.scenarios import cached_dataset, get_scenario
    from vo.dataset import open_dataset
    from vo.pipeline import run_and_evaluate

    unknown = set(bounds) - set(BOUND_KEYS)
    if unknown:
        raise SimError(f"unknown bound {sorted(unknown)[0]!r}; valid: {', '.join(BOUND_KEYS)}")
    config = get_scenario(scenario, overrides=overrides, seed=seed)
    path = cached_dataset(config, progress=progress)
    ds = open_dataset(path)
    res = run_and_evaluate(ds, estimator, out_dir=out_dir, options=options, progress=progress)
    figures = {key: float(fn(res.evaluation)) for key, (_, fn) in BOUND_KEYS.items()}
    failures = [{"bound": k, "value": figures[k], "limit": v,
                 "message": f"{BOUND_KEYS[k][0]} {figures[k]:.4f} > {v:g}"}
                for k, v in bounds.items() if v is not None and not figures[k] <= v]
    return CheckResult(scenario, estimator, str(path), figures, {k: v for k, v in bounds.items() if v is not None},
                       failures, res.run.n_lost)
