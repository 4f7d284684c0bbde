"""Relative pose error (RPE), pair selection and error definition as evo (``all_pairs=False``)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vo.errors import VoError
from vo.eval.rotation import angle_rad
from vo.eval.stats import ErrorStats
from rigs.geometry import inv_T
from rigs.trajectory import Trajectory

RPE_UNITS = ("frames", "m")
PAIRS_FROM = ("est", "gt")


@dataclass(frozen=True)
class RpeResult:
    """RPE over pose pairs ``(i, j)``: translation ``|t(E)|`` (m) and rotation ``angle(E)`` (deg),
    ``E = inv(inv(Q_i) Q_j) @ inv(P_i) P_j`` (Q gt, P estimate; TUM RGB-D / evo definition).

    ``pairs`` (K,2) and per-pair ``t_err_m``/``r_err_deg`` are kept for plots (not in ``to_dict``).
    """

    delta: float
    unit: str
    trans: ErrorStats
    rot_deg: ErrorStats
    pairs: np.ndarray = field(repr=False)
    t_err_m: np.ndarray = field(repr=False)
    r_err_deg: np.ndarray = field(repr=False)

    def to_dict(self) -> dict:
        return {"delta": self.delta, "unit": self.unit, "trans_m": self.trans.to_dict(),
                "rot_deg": self.rot_deg.to_dict()}


def pairs_by_frames(n: int, delta: int) -> np.ndarray:
    """evo ``filter_pairs_by_index`` (consecutive): ``(0, d), (d, 2d), ...`` -> (K,2) int."""
    ids = np.arange(0, n, delta)
    return np.stack([ids[:-1], ids[1:]], axis=1).astype(int)


def pairs_by_path(positions: np.ndarray, delta_m: float) -> np.ndarray:
    """evo ``filter_pairs_by_path`` (consecutive): walk the path from the last chosen index and pick
    the first index whose accumulated distance reaches ``delta_m``; chain the picks -> (K,2) int.

    The accumulation (reset to 0 at each pick, one segment at a time) is the same float sequence as
    evo's, so the same pairs come out even at the threshold.
    """
    ids, run = [0], 0.0
    for k in range(1, len(positions)):
        run += float(np.linalg.norm(positions[k] - positions[k - 1]))   # per-vector norm, as evo
        if run >= delta_m:
            ids.append(k)
            run = 0.0
    ids = np.asarray(ids, dtype=int)
    return np.stack([ids[:-1], ids[1:]], axis=1)


def rpe(gt: Trajectory, est: Trajectory, delta: float = 1, unit: str = "frames",
        pairs_from: str = "est") -> RpeResult:
    """RPE of associated trajectories for pose pairs ``delta`` frames or ``delta`` metres apart.

    ``pairs_from="est"`` picks metre pairs on the estimate's path as evo does by default
    (``pairs_from_reference=False``); ``"gt"`` uses the ground-truth path.
    """
    if unit not in RPE_UNITS:
        raise VoError(f"rpe: unknown delta unit {unit!r}; valid: {', '.join(RPE_UNITS)}")
    if pairs_from not in PAIRS_FROM:
        raise VoError(f"rpe: unknown pairs_from {pairs_from!r}; valid: {', '.join(PAIRS_FROM)}")
    if len(gt) != len(est) or len(gt) < 2:
        raise VoError(f"rpe: gt and est must be associated with >= 2 poses, got {len(gt)} and {len(est)}")
    if unit == "frames" and (delta < 1 or float(delta) != int(delta)):
        raise VoError(f"rpe: delta in frames must be a positive integer, got {delta}")
    if unit == "m" and not delta > 0:
        raise VoError(f"rpe: delta in metres must be > 0, got {delta}")
    src = est if pairs_from == "est" else gt
    pairs = pairs_by_frames(len(gt), int(delta)) if unit == "frames" else pairs_by_path(src.positions, float(delta))
    i, j = pairs[:, 0], pairs[:, 1]
    Q_rel = inv_T(gt.T[i]) @ gt.T[j]
    P_rel = inv_T(est.T[i]) @ est.T[j]
    E = inv_T(Q_rel) @ P_rel
    t_err = np.linalg.norm(E[:, :3, 3], axis=1)
    r_err = np.degrees(angle_rad(E[:, :3, :3]))
    return RpeResult(float(delta), unit, ErrorStats.of(t_err), ErrorStats.of(r_err), pairs, t_err, r_err)
