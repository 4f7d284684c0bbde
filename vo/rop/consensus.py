"""The four ROPs of one epoch pair: estimation against a prediction, inlier gates, rotation consensus.

Our extensions to seed 000 (which estimates each ROP independently):

* Prediction: every essential matrix is disambiguated against the ROP predicted from the epoch's
  rotation-only fit and the constant-velocity translation (planar scenes have a twin solution
  3-50 deg away; :func:`predicted_rops`).
* A ROP needs ``max(min_rop_inliers, min_inlier_ratio * matches)`` inliers.
* Rotation consensus (:func:`rotation_consensus`): every ROP implies an ``R_1_3``; a ROP more than
  ``max_rop_rotation_deg`` from the implied rotation that most others agree with is rejected. A
  2-2 tie between groups less than :data:`TWIN_DEG` apart keeps all four (the adjustment averages
  them); a tie further apart goes to the group closest to the rotation-only fit. On forward motion
  towards a texture-poor wall the same-camera ROPs 13 and 24 share their tracks and bend together
  by 0.5-3 deg while the cross ROPs 14 / 23 stay within ~0.2 deg, with equal inlier counts: the tie
  rule drops the bent pair. Indoor drift, seeds 0-3: 1.07 / 1.11 / 0.89 / 2.38 % without the rule,
  0.94 / 0.98 / 0.45 / 0.62 % with a 1 deg gate (docs/estimators.md).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from rigs.geometry import make_T, rotation_angle
from vo.rop.initial_eops import rotation_candidates
from vo.rop.relative import estimate_rop_normalized
from vo.rop.ropset import RopSet, exact_ropset

TWIN_DEG = 1.0               # 2-2 ties closer than this keep all four ROPs (never, at the default 1 deg gate)


def predicted_rops(R_1_3: np.ndarray, t_1_3: np.ndarray, T_c1_c2: np.ndarray) -> dict:
    """pair -> predicted ``(R_i_j, rhat_i_j)`` for a motion ``(R_1_3, t_1_3)`` (at rest: forward)."""
    if np.linalg.norm(t_1_3) < 1e-6:
        t_1_3 = np.array([0.0, 0.0, 1e-3])          # cross pairs barely care
    ex = exact_ropset(make_T(R_1_3, t_1_3), T_c1_c2)
    return {p: (m.R_i_j, m.rhat_i_j) for p, m in ex.rops.items()}


def solve_rops(pairs: dict, priors: dict, focal: float, T_c1_c2: np.ndarray, config) -> RopSet:
    """The epoch's ROPs from ``pairs`` (pair -> normalized matches) with the gates of
    :class:`~vo.rop.rop_config.RopConfig` ``config``; before the rotation consensus."""
    c, rops = config, {}
    for p, (x_i, x_j) in pairs.items():
        if len(x_i) < c.min_matches:
            continue
        m = estimate_rop_normalized(x_i, x_j, focal, c.seed, c.ransac_threshold_px, c.ransac_prob,
                                    max_iters=c.ransac_max_iters, prior=priors[p],
                                    loss=c.rop_loss)
        need = max(c.min_rop_inliers, c.min_inlier_ratio * len(x_i))
        if m.ok and m.n_inliers < need:
            m = dataclasses.replace(m, ok=False, message=f"{m.n_inliers} inliers < {need:.0f}")
        rops[p] = m
    return RopSet(rops, T_c1_c2, c.weights)


def rotation_consensus(ropset: RopSet, R_1_3: np.ndarray, gate_deg: float) -> RopSet:
    """``ropset`` with the ROPs off the rotation consensus marked not ok (module docstring);
    ``R_1_3`` the rotation-only fit that breaks ties."""
    ok = ropset.ok_pairs
    if len(ok) < 2:
        return ropset
    cands = dict(zip(ok, rotation_candidates(ropset, ok)[0]))
    gate = np.radians(gate_deg)
    dev = {(a, b): rotation_angle(cands[a].T @ cands[b]) for a in ok for b in ok}
    support = {a: sum(dev[a, b] <= gate for b in ok) for a in ok}
    best = max(support.values())
    tied = [a for a in ok if support[a] == best]
    if 2 * best == len(ok) and max(dev[a, b] for a in tied for b in tied) < np.radians(TWIN_DEG):
        return ropset
    ref = min(tied, key=lambda a: rotation_angle(cands[a].T @ R_1_3))
    rops = dict(ropset.rops)
    for p in ok:
        if dev[ref, p] > gate:
            rops[p] = dataclasses.replace(rops[p], ok=False,
                                          message=f"rotation {np.degrees(dev[ref, p]):.1f} deg off the consensus")
    return RopSet(rops, ropset.T_c1_c2, ropset.weighting)
