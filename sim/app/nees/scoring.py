"""Scoring of Monte-Carlo runs: pose errors, NEES against the chi-square interval, the NEES split into
error common to all runs and run-to-run spread, and the predicted vs measured end-point spread."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rigs.geometry import pose_error_left
from vo.errorprop.nees import nees, nees_split, summarize_nees


def pose_errors(gt_T_o_c0: np.ndarray, est_T_o_c0: np.ndarray) -> tuple:
    """(N,4,4) truth and estimate -> rotation errors (N,3) ``log(R_true R_est^T)`` (left perturbation,
    as FrameResult.cov defines it) and position errors (N,3) ``p_true - p_est``."""
    e = pose_error_left(gt_T_o_c0, est_T_o_c0)
    return e[:, :3], e[:, 3:]


def truth_per_run(T_true, runs: int) -> np.ndarray:
    """(R,N,4,4) truth: ``T_true`` (N,4,4) shared by all runs (``vary="noise"``) or already (R,N,4,4)."""
    T_true = np.asarray(T_true)
    return np.broadcast_to(T_true[None], (runs,) + T_true.shape) if T_true.ndim == 3 else T_true


def end_errors(runs_data: dict) -> tuple:
    """Per-run error of the last pose, ``runs_data`` as :func:`consistency` fills it (or ``runs.npz``):
    rotation (R,3) rad and position (R,3) m, left perturbation in the frame of each run's first true
    camera pose (x right, y down, z forward)."""
    T_est = runs_data["T_est"]
    rot, pos = [], []
    for T_t, T_e in zip(truth_per_run(runs_data["T_true"], len(T_est)), T_est):
        n = min(len(T_t), len(T_e))
        e_rot, e_pos = pose_errors(np.linalg.inv(T_t[0]) @ T_t[:n], np.asarray(T_e)[:n])
        rot.append(e_rot[-1])
        pos.append(e_pos[-1])
    return np.array(rot), np.array(pos)


@dataclass(frozen=True)
class ConsistencyResult:
    """What :func:`evaluate_runs` measured (built once, complete)."""

    scenario: str
    estimator: str
    runs: int
    t_s: np.ndarray = field(repr=False)
    distance_m: np.ndarray = field(repr=False)
    nees_pos: object = None            # vo.errorprop.NeesSummary
    nees_rot: object = None
    predicted_std_m: np.ndarray = field(default=None, repr=False)   # sqrt(trace P_pos), run-averaged
    measured_std_m: np.ndarray = field(default=None, repr=False)    # sqrt(trace of the sample covariance)
    n_frames_used: int = 0
    scored: np.ndarray = field(default=None, repr=False)             # indices of the scored timestamps
    mean_error_m: np.ndarray = field(default=None, repr=False)      # |run-mean position error| (common to all runs)
    split_pos: tuple = None      # (bias, spread) means over the scored timestamps, vo.errorprop.nees.nees_split
    split_rot: tuple = None
    vary: str = "noise"          # what changes between runs (module docstring)
    runs_data: dict = field(default=None, repr=False)   # per-run poses / covariances and truth (runs.npz)

    def end_ratio(self) -> float:
        return float(self.measured_std_m[-1] / self.predicted_std_m[-1])

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "estimator": self.estimator, "runs": self.runs, "vary": self.vary,
                "nees_position": self.nees_pos.to_dict(), "nees_attitude": self.nees_rot.to_dict(),
                "end_predicted_std_m": float(self.predicted_std_m[-1]),
                "end_measured_std_m": float(self.measured_std_m[-1]),
                "end_measured_over_predicted": self.end_ratio(), "n_frames_used": self.n_frames_used,
                "nees_position_bias_spread": list(self.split_pos), "nees_attitude_bias_spread": list(self.split_rot),
                "path_length_m": float(self.distance_m[-1])}

    def text(self) -> str:
        p, r = self.nees_pos, self.nees_rot
        return "\n".join([
            f"consistency of {self.estimator} on {self.scenario}: {self.runs} runs (vary {self.vary}), "
            f"{self.n_frames_used} timestamps",
            f"  position NEES: mean {p.overall_mean:.2f} (dof 3; mean/3 = {p.overall_mean / 3:.2f}), "
            f"inside 95% interval [{p.bounds[0]:.2f}, {p.bounds[1]:.2f}] at {100 * p.fraction_inside:.1f}% of timestamps",
            f"  attitude NEES: mean {r.overall_mean:.2f} (dof 3; mean/3 = {r.overall_mean / 3:.2f}), "
            f"inside at {100 * r.fraction_inside:.1f}% of timestamps",
            f"  NEES split (common error over runs / run-to-run spread, expected {3 / self.runs:.2f} / 3): position "
            f"{self.split_pos[0]:.2f} / {self.split_pos[1]:.2f}, "
            f"attitude {self.split_rot[0]:.2f} / {self.split_rot[1]:.2f}",
            f"  end-point error std: predicted {self.predicted_std_m[-1]:.4f} m, measured {self.measured_std_m[-1]:.4f} m"
            f" (ratio {self.end_ratio():.2f}) after {self.distance_m[-1]:.1f} m",
        ])


MIN_DISTANCE_M = 0.05   # timestamps before the cart has moved this far are not scored (see evaluate_runs)


def evaluate_runs(scenario: str, estimator: str, gt_T_o_c0: np.ndarray, t_s: np.ndarray, est_T: list, covs: list,
                  min_distance_m: float = MIN_DISTANCE_M, vary: str = "noise",
                  keep_runs: bool = False) -> ConsistencyResult:
    """NEES and spread from ``runs`` estimates: ``gt_T_o_c0`` (N,4,4) truth in the estimator's frame O
    (or (R,N,4,4), one per run; distance is measured along run 0's),
    ``est_T`` / ``covs`` lists (one per run) of (n_k,4,4) poses and (n_k,6,6) covariances of
    ``[rotvec, position]`` of ``T_o_c0`` as the estimator reported them (runs are cut to the shortest).
    ``vary`` describes what changed between runs; ``keep_runs``: the result keeps the per-run poses,
    covariances and truth (``runs_data``).

    Timestamps before the truth has moved ``min_distance_m`` are not scored: the first pose is the
    anchor (zero error, zero covariance), and while the cart stands still a VO that detects
    standstill (rop's rotation-only epochs) returns the exact zero translation, so the NEES is ~0
    by construction and says nothing about the covariance."""
    n = min(len(e) for e in est_T)
    T_est = np.array([np.asarray(e)[:n] for e in est_T])
    P = np.array([np.asarray(c)[:n] for c in covs])
    gt = truth_per_run(gt_T_o_c0, len(T_est))                                         # (R, N, 4, 4)
    errs = [pose_errors(g[:n], T) for g, T in zip(gt, T_est)]
    e_rot, e_pos = np.array([e[0] for e in errs]), np.array([e[1] for e in errs])
    dist = np.r_[0, np.cumsum(np.linalg.norm(np.diff(gt[0, :n, :3, 3], axis=0), axis=1))]
    sl = np.flatnonzero(dist >= max(min_distance_m, 1e-12))
    ne_pos = nees(e_pos[:, sl], P[:, sl, 3:, 3:])
    ne_rot = nees(e_rot[:, sl], P[:, sl, :3, :3])
    pred = np.sqrt(np.trace(P[:, :, 3:, 3:], axis1=2, axis2=3).mean(axis=0))
    meas = np.sqrt(np.array([np.trace(np.cov(e_pos[:, t].T)) for t in range(n)]))
    split_pos = tuple(float(np.mean(x)) for x in nees_split(e_pos[:, sl], P[:, sl, 3:, 3:]))
    split_rot = tuple(float(np.mean(x)) for x in nees_split(e_rot[:, sl], P[:, sl, :3, :3]))
    runs_data = dict(T_true=np.asarray(gt_T_o_c0), t_s=np.asarray(t_s), T_est=T_est, cov=P) if keep_runs else None
    return ConsistencyResult(scenario, estimator, len(T_est), np.asarray(t_s)[:n], dist, summarize_nees(ne_pos, 3),
                             summarize_nees(ne_rot, 3), pred, meas, len(sl), sl,
                             np.linalg.norm(e_pos.mean(axis=0), axis=1), split_pos, split_rot, vary, runs_data)
