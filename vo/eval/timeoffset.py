"""Does a constant time offset explain the estimate far better? A search over offsets.

An estimate stamped on another clock (shifted by a constant) associates to the wrong ground-truth
poses, or to none: its ATE then measures the motion during the shift, not the estimator. For an
offset ``d`` the estimate's times become ``t + d``; :func:`search_offset` tries the offsets that put
the estimate's middle pose on a ground-truth time (every such offset on a coarse grid of at most
``max_candidates``, then every one between the best coarse candidate's neighbours), associates,
aligns (the evaluation's own method) and keeps the smallest ATE RMSE among the offsets that match
at least half as many poses as the best-matching one. :func:`offset_warning` reports it when it
matches at least twice as many poses as the offset in use, or gives an ATE RMSE at least
:data:`FAR_BETTER` times smaller.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from vo.errors import VoError
from vo.eval.align import align as align_traj
from vo.eval.associate import associate
from rigs.trajectory import Trajectory

FAR_BETTER = 3.0          # an ATE this many times smaller is "far better"
MAX_CANDIDATES = 200      # coarse grid size; the refinement adds at most the candidates between two grid points


@dataclass(frozen=True)
class OffsetFit:
    """At ``offset_ns``: ``n_matched`` estimate poses associated, ATE RMSE ``ate_m`` (NaN under 2 matches)."""

    offset_ns: int
    n_matched: int
    ate_m: float

    @property
    def offset_s(self) -> float:
        return self.offset_ns * 1e-9


def shifted(est: Trajectory, offset_ns: int) -> Trajectory:
    """``est`` with every timestamp plus ``offset_ns``."""
    return Trajectory(est.t_ns + np.int64(offset_ns), est.T, est.ref, est.frame)


def fit_at(gt: Trajectory, est: Trajectory, offset_ns: int, align: str, max_diff_ns: int) -> OffsetFit:
    """Associate ``est`` shifted by ``offset_ns`` to ``gt``, align with ``align``, ATE RMSE."""
    try:
        gt_m, est_m = associate(gt, shifted(est, offset_ns), max_diff_ns)
    except VoError:                  # not one pair
        return OffsetFit(int(offset_ns), 0, float("nan"))
    if len(gt_m) < 2:
        return OffsetFit(int(offset_ns), len(gt_m), float("nan"))
    try:
        est_a, _ = align_traj(est_m, gt_m, align)
    except VoError:                  # e.g. too few points for an Umeyama fit
        return OffsetFit(int(offset_ns), len(gt_m), float("nan"))
    err = np.linalg.norm(est_a.positions - gt_m.positions, axis=1)
    return OffsetFit(int(offset_ns), len(gt_m), float(np.sqrt(np.mean(err ** 2))))


def search_offset(gt: Trajectory, est: Trajectory, align: str, max_diff_ns: int,
                  max_candidates: int = MAX_CANDIDATES) -> Optional[OffsetFit]:
    """The offset that explains ``est`` best (see the module docstring); None when no offset matches 2 poses."""
    if len(gt) < 2 or len(est) < 2:
        return None
    candidates = np.unique(gt.t_ns - est.t_ns[len(est) // 2])
    stride = max(1, int(np.ceil(len(candidates) / max_candidates)))
    coarse = [fit_at(gt, est, int(d), align, max_diff_ns) for d in candidates[::stride]]
    best = _best(coarse)
    if best is None:
        return None
    if stride > 1:
        k = int(np.searchsorted(candidates, best.offset_ns))
        fine = candidates[max(0, k - stride):k + stride + 1]
        best = _best([best] + [fit_at(gt, est, int(d), align, max_diff_ns) for d in fine if d != best.offset_ns])
    return best


def _best(fits: list) -> Optional[OffsetFit]:
    n_max = max((f.n_matched for f in fits), default=0)
    ok = [f for f in fits if f.n_matched >= max(2, n_max / 2) and np.isfinite(f.ate_m)]
    return min(ok, key=lambda f: (f.ate_m, abs(f.offset_ns))) if ok else None


def offset_warning(gt: Trajectory, est: Trajectory, offset_ns: int, align: str, max_diff_ns: int
                   ) -> Optional[str]:
    """One line suggesting ``--t-offset`` when another constant offset explains ``est`` far better than
    ``offset_ns`` (the one in use), else None."""
    now = fit_at(gt, est, offset_ns, align, max_diff_ns)
    best = search_offset(gt, est, align, max_diff_ns)
    if best is None or abs(best.offset_ns - offset_ns) <= max_diff_ns:
        return None
    more = best.n_matched >= 2 * max(now.n_matched, 1)
    better = np.isfinite(now.ate_m) and best.ate_m * FAR_BETTER <= now.ate_m
    if not (more or better):
        return None
    now_ate = f"{now.ate_m:.4f} m" if np.isfinite(now.ate_m) else "not measurable"
    return (f"a constant time offset explains the estimate far better: with --t-offset {best.offset_s:.6g} "
            f"(seconds added to the estimate's timestamps) {best.n_matched} of {len(est)} poses match and ATE "
            f"RMSE is {best.ate_m:.4f} m; at the offset in use ({offset_ns * 1e-9:.6g} s) {now.n_matched} match, "
            f"ATE RMSE {now_ate}")
