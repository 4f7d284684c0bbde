"""Plot of a consistency run: run-averaged NEES per timestamp with its 95 % band, and predicted vs
measured position-error spread against distance."""
from __future__ import annotations

from sim.app.nees.scoring import ConsistencyResult


def plot_consistency(res: ConsistencyResult, path) -> None:
    """NEES per timestamp with the 95% band, and predicted vs measured error spread against distance."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    d = res.distance_m[res.scored] if res.scored is not None else res.distance_m[1:]
    for s, label, c in ((res.nees_pos, "position", "b"), (res.nees_rot, "attitude", "g")):
        axes[0].plot(d, s.mean_nees, c, label=f"{label} ({100 * s.fraction_inside:.0f}% inside)")
    lo, hi = res.nees_pos.bounds
    axes[0].axhspan(lo, hi, color="k", alpha=0.12, label="95% interval")
    axes[0].set_yscale("log")
    axes[0].set_xlabel("distance travelled (m)")
    axes[0].set_ylabel(f"NEES averaged over {res.runs} runs")
    axes[0].legend(fontsize=8)
    source = "re-noised replicates" if "re-noised" in res.vary else "estimator's covariance"
    axes[1].plot(res.distance_m, res.predicted_std_m, "k-", label=f"predicted ({source})")
    axes[1].plot(res.distance_m, res.measured_std_m, "r.", ms=3, label="Monte-Carlo spread")
    if res.mean_error_m is not None:
        axes[1].plot(res.distance_m, res.mean_error_m, "c--", lw=1, label="|run-mean error| (common to all runs)")
    axes[1].set_xlabel("distance travelled (m)")
    axes[1].set_ylabel("position error (m)")
    axes[1].legend(fontsize=8)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{res.estimator} on {res.scenario}, {res.runs} runs, vary {res.vary}")
    from vo.eval.plots import save_figure
    save_figure(fig, path)
