"""Evaluation plots (matplotlib Agg); every file is written atomically (:mod:`rigs.atomic_io`)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rigs.figures import save_figure
from rigs.trajectory import Trajectory
from vo.eval.align import alignment_header
from vo.eval.associate import associate
from vo.eval.rpe import RpeResult


def plot_topdown(results: dict, gt: Trajectory, gcps=None, path="topdown.png") -> Path:
    """x-y view: ``gt`` black, each aligned estimate (name -> Trajectory) coloured, GCPs as named red dots."""
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(gt.positions[:, 0], gt.positions[:, 1], "k-", lw=1.5, label="ground truth")
    for name, est in results.items():
        ax.plot(est.positions[:, 0], est.positions[:, 1], lw=1.2, label=name)
    for g in gcps or []:
        ax.plot(g.p_w_c0[0], g.p_w_c0[1], "o", color="red", ms=5)
        ax.annotate(g.name, (g.p_w_c0[0], g.p_w_c0[1]), textcoords="offset points", xytext=(4, 4),
                    fontsize=8, color="red")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return save_figure(fig, path)


def error_vs_distance(gt: Trajectory, est: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(K,) distance travelled along gt (m) and (K,) position error |p_est - p_gt| (m) at matched poses."""
    gt_m, est_m = associate(gt, est)
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(gt_m.positions, axis=0), axis=1))])
    return dist, np.linalg.norm(est_m.positions - gt_m.positions, axis=1)


def plot_error_vs_distance(gt: Trajectory, ests: dict, path="error_vs_distance.png") -> Path:
    """Position error of each aligned estimate (name -> Trajectory) against distance along gt."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for name, est in ests.items():
        d, e = error_vs_distance(gt, est)
        ax.plot(d, e, lw=1.2, label=name)
    ax.set_xlabel("distance travelled (m)")
    ax.set_ylabel("position error (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return save_figure(fig, path)


def plot_rpe(rpes: dict, path="rpe.png") -> Path:
    """Per-pair RPE translation (m) and rotation (deg) of each result (name -> RpeResult)."""
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    for name, r in rpes.items():
        assert isinstance(r, RpeResult)
        a1.plot(r.pairs[:, 0], r.t_err_m, lw=1.0, label=name)
        a2.plot(r.pairs[:, 0], r.r_err_deg, lw=1.0, label=name)
    a1.set_ylabel("RPE trans (m)")
    a2.set_ylabel("RPE rot (deg)")
    a2.set_xlabel("pose index of pair start")
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    a1.legend(loc="best", fontsize=8)
    return save_figure(fig, path)


def plot_evaluation(result, gcps, out_dir) -> list:
    """The three plots of one :class:`vo.eval.EvalResult` (top-down, error vs distance, RPE) in ``out_dir``."""
    out = Path(out_dir)
    est = {"estimate": result.aligned_est}
    return [plot_topdown(est, result.gt_matched, gcps, out / "topdown.png"),
            plot_error_vs_distance(result.gt_matched, est, out / "error_vs_distance.png"),
            plot_rpe({"estimate": result.rpe_frame}, out / "rpe.png")]


def plot_comparison(results: dict, gt: Trajectory, path="comparison.png") -> Path:
    """One figure comparing estimates (name -> :class:`vo.eval.EvalResult`): top-down view of the
    aligned estimates over ``gt``, position error against distance, and the ATE distribution per estimate."""
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(16, 5))
    a1.plot(gt.positions[:, 0], gt.positions[:, 1], "k-", lw=1.5, label="ground truth")
    for name, r in results.items():
        a1.plot(r.aligned_est.positions[:, 0], r.aligned_est.positions[:, 1], lw=1.2, label=name)
        d, e = error_vs_distance(r.gt_matched, r.aligned_est)
        a2.plot(d, e, lw=1.2, label=name)
    a1.set_xlabel("x (m)")
    a1.set_ylabel("y (m)")
    a1.set_aspect("equal", adjustable="datalim")
    a2.set_xlabel("distance travelled (m)")
    a2.set_ylabel("position error (m)")
    a3.boxplot([r.ape.t_err_m for r in results.values()], showfliers=False)
    a3.set_xticks(range(1, len(results) + 1), list(results))
    a3.set_ylabel("ATE translation (m)")
    a3.tick_params(axis="x", labelrotation=20)
    for a in (a1, a2, a3):
        a.grid(True, alpha=0.3)
    a1.legend(loc="best", fontsize=8)
    method = next(iter(results.values())).alignment.method
    fig.suptitle(f"alignment: {alignment_header(method)}", fontsize=9)
    return save_figure(fig, path)
