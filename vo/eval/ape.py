"""Absolute trajectory error (ATE / APE) of an already aligned, associated estimate."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vo.errors import VoError
from vo.eval.rotation import angle_rad
from vo.eval.stats import ErrorStats
from rigs.trajectory import Trajectory


@dataclass(frozen=True)
class ApeResult:
    """Translation error ``|p_est - p_gt|`` (m) and rotation error ``angle(R_gt^T R_est)`` (deg).

    ``t_err_m`` / ``r_err_deg`` (N,) keep the per-pose errors (for plots; not in ``to_dict``).
    """

    trans: ErrorStats
    rot_deg: ErrorStats
    t_ns: np.ndarray = field(repr=False)
    t_err_m: np.ndarray = field(repr=False)
    r_err_deg: np.ndarray = field(repr=False)

    @property
    def rmse_m(self) -> float:
        return self.trans.rmse

    @property
    def rot_rmse_deg(self) -> float:
        return self.rot_deg.rmse

    def to_dict(self) -> dict:
        return {"trans_m": self.trans.to_dict(), "rot_deg": self.rot_deg.to_dict()}


def ate(gt: Trajectory, est: Trajectory) -> ApeResult:
    """ATE of associated, already aligned trajectories (pose k of ``est`` matched to pose k of ``gt``).

    Same figures as evo's ``APE`` with ``translation_part`` (and ``rotation_angle_deg``).
    """
    if len(gt) != len(est) or len(gt) == 0:
        raise VoError(f"ate: gt and est must be associated (same non-zero length), got {len(gt)} and {len(est)}")
    t_err = np.linalg.norm(est.positions - gt.positions, axis=1)
    R_err = np.einsum("nji,njk->nik", gt.rotations, est.rotations)   # R_gt^T R_est
    r_err = np.degrees(angle_rad(R_err))
    return ApeResult(ErrorStats.of(t_err), ErrorStats.of(r_err), gt.t_ns.copy(), t_err, r_err)
