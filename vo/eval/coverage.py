"""How much of the ground truth an estimate covers: matched poses and the time span they span."""
from __future__ import annotations

from dataclasses import dataclass

from rigs.trajectory import Trajectory


@dataclass(frozen=True)
class Coverage:
    """``n_matched`` of the ``n_reference`` ground-truth poses (the dataset's frames) have an estimate
    within the association tolerance; ``fraction = n_matched / n_reference``. ``span_s`` is the time
    between the first and last matched pose, ``reference_span_s`` that of the whole ground truth;
    ``n_estimate`` counts the poses the estimate file holds."""

    n_matched: int
    n_reference: int
    n_estimate: int
    span_s: float
    reference_span_s: float

    @property
    def fraction(self) -> float:
        return self.n_matched / self.n_reference if self.n_reference else 0.0

    def to_dict(self) -> dict:
        return {"n_matched": self.n_matched, "n_reference": self.n_reference, "n_estimate": self.n_estimate,
                "fraction": self.fraction, "span_s": self.span_s, "reference_span_s": self.reference_span_s}

    def text(self) -> str:
        return (f"{self.n_matched} of {self.n_reference} poses matched ({100 * self.fraction:.1f} %), "
                f"{self.span_s:.2f} s of {self.reference_span_s:.2f} s")


def coverage(gt: Trajectory, est: Trajectory, gt_matched: Trajectory) -> Coverage:
    """Coverage of ``gt`` (every pose) by ``est`` given the associated subset ``gt_matched``."""
    def span(t):
        return float((t.t_ns[-1] - t.t_ns[0]) * 1e-9) if len(t) > 1 else 0.0
    return Coverage(len(gt_matched), len(gt), len(est), span(gt_matched), span(gt))
