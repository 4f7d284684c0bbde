"""One call that associates, aligns and runs every metric."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rigs.records import Gcp
from vo.errors import VoError
from vo.eval.align import AlignInfo, align as align_traj, alignment_header
from vo.eval.associate import DEFAULT_MAX_DIFF_NS, associate
from vo.eval.coverage import Coverage, coverage
from vo.eval.frames import frame_warning
from vo.eval.timeoffset import offset_warning, shifted
from vo.estimators.base import FRAME_CLASSES, PRODUCED_CLASSES
from vo.eval.metrics import (ApeResult, DriftResult, GcpTable, KittiResult, RpeResult, ate, drift, gcp_errors,
                             kitti_errors, rpe)
from rigs.trajectory import Trajectory


@dataclass(frozen=True)
class EvalResult:
    """Everything :func:`evaluate` computed; ``aligned_est`` / ``gt_matched`` are the associated pair."""

    n_matched: int
    alignment: AlignInfo
    ape: ApeResult
    rpe_frame: RpeResult
    rpe_m: RpeResult | None
    drift: DriftResult
    kitti: KittiResult
    gcps: GcpTable | None
    aligned_est: Trajectory
    gt_matched: Trajectory
    coverage: Coverage
    warnings: tuple = ()
    frames_by_status: dict = field(default_factory=dict)
    t_offset_ns: int = 0

    def to_dict(self) -> dict:
        return {"n_matched": self.n_matched, "coverage": self.coverage.to_dict(), "warnings": list(self.warnings),
                "frames_by_status": dict(self.frames_by_status), "t_offset_s": self.t_offset_ns * 1e-9,
                "alignment": self.alignment.to_dict(), "ape": self.ape.to_dict(),
                "rpe_frame": self.rpe_frame.to_dict(), "rpe_m": self.rpe_m.to_dict() if self.rpe_m else None,
                "drift": self.drift.to_dict(), "kitti": self.kitti.to_dict(),
                "gcps": self.gcps.to_dict() if self.gcps else None}

    def table(self) -> str:
        """Plain-text report: ATE, RPE, drift, KITTI and (if given) the seed 000 GCP table."""
        a, r, d, k = self.ape, self.rpe_frame, self.drift, self.kitti
        lines = [f"frames by status    {status_text(self.frames_by_status)}",
                 f"coverage            {self.coverage.text()}   (alignment: {self.alignment.method}, "
                 f"scale {self.alignment.s:.6f})"]
        if self.t_offset_ns:
            lines.append(f"time offset         {self.t_offset_ns * 1e-9:+.6g} s added to the estimate's timestamps")
        lines += [
                 _stats_line("ATE trans (m)", a.trans), _stats_line("ATE rot (deg)", a.rot_deg),
                 _stats_line("RPE/frame t (m)", r.trans), _stats_line("RPE/frame r (deg)", r.rot_deg)]
        if self.rpe_m is not None:
            lines += [_stats_line(f"RPE/{self.rpe_m.delta:g}m t (m)", self.rpe_m.trans),
                      _stats_line(f"RPE/{self.rpe_m.delta:g}m r (deg)", self.rpe_m.rot_deg)]
        lines += [f"drift               end diff {d.end_diff_m:.3f} m over {d.gt_length_m:.3f} m gt route "
                  f"({d.drift_ratio_pct:.2f} %); est path {d.est_length_m:.3f} m",
                  f"KITTI               t_err {k.t_err_pct:.3f} %  r_err {k.r_err_deg_per_m:.5f} deg/m  "
                  f"({k.n_segments} segments, lengths {', '.join(f'{v:.2f}' for v in k.lengths_m)} m"
                  f"{', scaled to route' if k.scaled else ''})"]
        if self.gcps is not None:
            lines += ["", self.gcps.text()]
        lines += [f"warning: {w}" for w in self.warnings]
        lines.insert(0, f"alignment           {alignment_header(self.alignment.method, self.alignment.s)}")
        return "\n".join(lines)


def status_text(counts: dict) -> str:
    """``ok 58, coasting 2, init 1, lost 0`` (classes of :data:`vo.estimators.base.FRAME_CLASSES`)."""
    return ", ".join(f"{c} {counts.get(c, 0)}" for c in FRAME_CLASSES)


def _stats_line(label: str, s) -> str:
    return (f"{label:<20}rmse {s.rmse:.4f}  mean {s.mean:.4f}  median {s.median:.4f}  "
            f"std {s.std:.4f}  max {s.max:.4f}")


def evaluate(gt: Trajectory, est: Trajectory, gcps: list[Gcp] | None = None, align: str = "first",
             max_diff_ns: int = DEFAULT_MAX_DIFF_NS, rpe_delta_m: float | None = None,
             pose_classes=None, t_offset_ns: int = 0, offset_check: bool = False) -> EvalResult:
    """Associate ``est`` to ``gt``, align (``align`` method), and run ATE, RPE (1 frame and, if the path
    allows, ``rpe_delta_m`` metres - default 10% of the gt path), drift, KITTI and GCP errors.

    ``pose_classes`` (N,) gives each estimate pose's class (:data:`~vo.estimators.base.FRAME_CLASSES`;
    None: every pose ok): only produced poses (ok, coasting) are scored, placeholders (init, lost)
    count as not covered; the counts are reported. ``t_offset_ns`` is added to the estimate's
    timestamps before association. Coverage counts the gt poses matched (``gt`` at the frame times:
    the dataset's frames). Drift is taken against the end of the whole gt route (from the first
    matched pose), so an estimate that stops early is charged for the rest. GCPs outside the matched
    time span are not scored. Warnings: a rotation error after alignment over a few degrees (the frames
    differ, :mod:`vo.eval.frames`); fewer than half the scored poses associated; with ``offset_check``,
    a constant time offset that explains the estimate far better (:mod:`vo.eval.timeoffset`)."""
    if rpe_delta_m is not None and not (math.isfinite(rpe_delta_m) and rpe_delta_m > 0):
        raise VoError(f"rpe_delta_m: must be a finite number > 0, got {rpe_delta_m!r}")
    classes = np.full(len(est), "ok", dtype=object) if pose_classes is None else np.asarray(pose_classes, object)
    if classes.shape != (len(est),) or not set(classes) <= set(FRAME_CLASSES):
        raise VoError(f"evaluate: pose_classes must be one of {', '.join(FRAME_CLASSES)} per estimate pose "
                      f"({len(est)}), got {classes.shape[0]} values {sorted(set(map(str, classes)))[:4]}")
    counts = {c: int(np.sum(classes == c)) for c in FRAME_CLASSES}
    produced = np.isin(classes, PRODUCED_CLASSES)
    if not produced.any():
        raise VoError(f"evaluate: the estimate holds no estimated pose ({status_text(counts)}): "
                      f"the estimator never initialised")
    est_produced = est.subset(produced)
    hint = offset_warning(gt, est_produced, t_offset_ns, align, max_diff_ns) if offset_check else None
    est = shifted(est_produced, t_offset_ns)
    try:
        gt_m, est_m = associate(gt, est, max_diff_ns)
    except VoError:                   # not one pair
        gt_m = est_m = gt.subset(np.zeros(len(gt), dtype=bool))
    warnings = []
    if len(gt_m) < 2:
        raise VoError(f"evaluate: only {len(gt_m)} of {len(gt)} ground-truth poses matched one of the {len(est)} "
                      f"estimated poses within {max_diff_ns * 1e-6:g} ms; need at least 2"
                      + (f"; {hint}" if hint else ""))
    if len(est_m) < 0.5 * len(est):
        warnings.append(f"only {len(est_m)} of {len(est)} estimated poses matched a ground-truth pose within "
                        f"{max_diff_ns * 1e-6:g} ms: most of the estimate is not evaluated (timestamps on "
                        f"another clock, or another rate?)")
    if hint:
        warnings.append(hint)
    est_a, info = align_traj(est_m, gt_m, align)
    delta_m = rpe_delta_m if rpe_delta_m is not None else round(0.1 * gt_m.path_length, 3)
    rpe_m = rpe(gt_m, est_a, delta_m, "m") if delta_m > 0 else None
    route = gt.subset(gt.t_ns >= gt_m.t_ns[0])
    d = drift(gt_m, est_a, route)
    gcps = [g for g in (gcps or []) if est_a.t_ns[0] <= g.t_ns <= est_a.t_ns[-1]]
    table = gcp_errors(est_a, gcps, d) if gcps else None
    ape = ate(gt_m, est_a)
    warning = frame_warning(gt_m, est_a, ape.rot_rmse_deg)
    return EvalResult(len(gt_m), info, ape, rpe(gt_m, est_a, 1, "frames"), rpe_m, d,
                      kitti_errors(gt_m, est_a), table, est_a, gt_m, coverage(gt, est, gt_m),
                      tuple(([warning] if warning else []) + warnings), counts, int(t_offset_ns))
