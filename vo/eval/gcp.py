"""Check-point (GCP) differences and the seed 000 Table 4 layout."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs.records import Gcp
from vo.errors import VoError
from vo.eval.associate import interpolate_T
from vo.eval.drift import DriftResult
from rigs.trajectory import Trajectory


@dataclass(frozen=True)
class GcpRow:
    """One check point: ``d_xyz = p_est(t_ns) - p_w_c0`` (m)."""

    name: str
    t_ns: int
    d_xyz: tuple

    def to_dict(self) -> dict:
        return {"name": self.name, "t_ns": self.t_ns, "d_xyz": list(self.d_xyz)}


@dataclass(frozen=True)
class GcpTable:
    """Per-GCP differences, ``mean_xyz`` and ``rmsd_xyz = sqrt(mean(d^2))`` per axis, optional drift."""

    rows: tuple
    mean_xyz: tuple
    rmsd_xyz: tuple
    drift: DriftResult | None = None

    def to_dict(self) -> dict:
        return {"rows": [r.to_dict() for r in self.rows], "mean_xyz": list(self.mean_xyz),
                "rmsd_xyz": list(self.rmsd_xyz), "drift": self.drift.to_dict() if self.drift else None}

    def text(self) -> str:
        """Seed 000 Table 4 layout: GCP rows, Mean Diff., RMSD (m) +-, lengths, Total diff., Drift ratio."""
        head = f"{'GCP':<26}{'Diff. X (m)':>13}{'Diff. Y (m)':>13}{'Diff. Z (m)':>13}"
        lines = [head, "-" * len(head)]
        for r in self.rows:
            lines.append(f"{r.name:<26}" + "".join(f"{v:>13.3f}" for v in r.d_xyz))
        lines.append(f"{'Mean Diff. (m)':<26}" + "".join(f"{v:>13.3f}" for v in self.mean_xyz))
        lines.append(f"{'RMSD (m)':<26}" + "".join(f"{'± %.3f' % v:>13}" for v in self.rmsd_xyz))
        if self.drift is not None:
            d = self.drift
            for label, v in (("Total length for GCP (m)", f"{d.gt_length_m:.3f}"),
                             ("Total length for SVO (m)", f"{d.est_length_m:.3f}"),
                             ("Total diff. (m)", f"{d.end_diff_m:.3f}"),
                             ("Drift ratio (%)", f"{d.drift_ratio_pct:.2f}")):
                lines.append(f"{label:<26}{v:>39}")
        return "\n".join(lines)

    __str__ = text


def gcp_errors(est: Trajectory, gcps: list[Gcp], drift: DriftResult | None = None) -> GcpTable:
    """Differences ``est - truth`` at each GCP's pass time (estimate interpolated there).

    ``est`` must be the aligned left-camera trajectory ``T_w_c0`` (GCP truth is ``gcp.p_w_c0``).
    GCPs whose time is outside the estimate's range raise VoError naming the GCP.
    """
    if not gcps:
        raise VoError("gcp_errors: no GCPs given")
    rows = []
    for g in gcps:
        if not (est.t_ns[0] <= int(g.t_ns) <= est.t_ns[-1]):
            raise VoError(f"gcp_errors: GCP {g.name!r} time {int(g.t_ns)} ns outside estimate range "
                          f"{est.t_ns[0]}..{est.t_ns[-1]} ns")
        p = interpolate_T(est, [int(g.t_ns)])[0, :3, 3]
        rows.append(GcpRow(g.name, int(g.t_ns), tuple(float(v) for v in p - np.asarray(g.p_w_c0, float))))
    D = np.array([r.d_xyz for r in rows])
    return GcpTable(tuple(rows), tuple(D.mean(0).tolist()), tuple(np.sqrt((D ** 2).mean(0)).tolist()), drift)
