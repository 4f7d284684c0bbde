"""Seed 000's end-point drift: total difference and drift ratio over the route (Tables 4 and 5)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.errors import VoError
from rigs.trajectory import Trajectory


@dataclass(frozen=True)
class DriftResult:
    """``end_diff_m = |p_est(end) - p_gt(end)|`` ("Total diff."), ``drift_ratio_pct = 100 end_diff / gt_length``.

    ``gt_length_m`` is "Total length for GCP", ``est_length_m`` "Total length for SVO" (each
    trajectory's own summed path). Seed 000's printed figures (0.662 = 91.837 - 91.175 and
    0.259 = 21.000 - 20.741) also equal the difference of the two lengths, while its text defines
    the total difference "based on the endpoint"; we follow the text (end point) and report the
    length difference separately as ``length_diff_m`` / ``length_ratio_pct``.
    """

    gt_length_m: float
    est_length_m: float
    end_diff_m: float
    end_diff_xyz: tuple
    drift_ratio_pct: float
    length_diff_m: float
    length_ratio_pct: float

    def to_dict(self) -> dict:
        return {"gt_length_m": self.gt_length_m, "est_length_m": self.est_length_m,
                "end_diff_m": self.end_diff_m, "end_diff_xyz": list(self.end_diff_xyz),
                "drift_ratio_pct": self.drift_ratio_pct, "length_diff_m": self.length_diff_m,
                "length_ratio_pct": self.length_ratio_pct}


def drift(gt: Trajectory, est: Trajectory, route: Trajectory | None = None) -> DriftResult:
    """End-point drift of associated trajectories (align with ``"first"`` before).

    ``route`` is the whole ground-truth route from the first matched pose on (default ``gt``): the
    end difference is taken against the route's last pose and the ratio over the route's length, so
    an estimate that stops early is charged for the part it did not cover. With an estimate that
    covers the route, ``route`` and ``gt`` end at the same pose and both give the same figures.
    Ratios are NaN when the gt path length is zero."""
    if len(gt) != len(est) or len(gt) < 2:
        raise VoError(f"drift: gt and est must be associated with >= 2 poses, got {len(gt)} and {len(est)}")
    route = gt if route is None else route
    L_gt, L_est = route.path_length, est.path_length
    d = est.positions[-1] - route.positions[-1]
    end = float(np.linalg.norm(d))
    pct = (lambda x: 100.0 * x / L_gt) if L_gt > 0 else (lambda x: float("nan"))   # NaN for a standstill
    return DriftResult(L_gt, L_est, end, tuple(float(v) for v in d), pct(end), L_est - L_gt, pct(abs(L_est - L_gt)))
