"""Seed 002's Figures 12-15 from VINS runs (matplotlib Agg; written atomically by :func:`vo.eval.plots.save_figure`).

* Fig. 12 :func:`plot_rpe_over_time`: the relative positioning error of each configuration over time;
* Fig. 13 :func:`plot_features`: one image with its tracked features, static green and dynamic red (from the
  true segmentation), filled when the paper's rule calls them inliers (N >= 10), hollow when outliers (N < 10);
* Fig. 14/15 :func:`plot_weights_and_error`: g_f (and the times tracked N) over time above the error of the
  configuration that uses them.
"""
from __future__ import annotations

import numpy as np

from vo.eval.plots import plt, save_figure

N_INLIER = 10      # seed 002's evaluation rule: a feature tracked fewer times is an outlier


def plot_rpe_over_time(series: dict, path, delta_label: str = "10 frames"):
    """``series``: name -> (t_s, RPE translation m); one line per configuration (Fig. 12)."""
    fig, ax = plt.subplots(figsize=(7, 3.2))
    for name, (t, err) in series.items():
        if len(t):
            ax.plot(t, err, ".-", lw=1.0, ms=3, label=f"{name} (mean {np.mean(err):.2f} m)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"RPE over {delta_label} (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return save_figure(fig, path)


def plot_features(image: np.ndarray, px: np.ndarray, dynamic: np.ndarray, counts: np.ndarray, path, title: str = ""):
    """``image`` (h,w) grey; ``px`` (n,2) tracked features, ``dynamic`` (n,) true labels, ``counts`` (n,) N (Fig. 13)."""
    px, dynamic, counts = np.asarray(px, float).reshape(-1, 2), np.asarray(dynamic, bool), np.asarray(counts)
    h, w = image.shape[:2]
    fig, ax = plt.subplots(figsize=(w / 100, h / 100 + 0.4))
    ax.imshow(image, cmap="gray", vmin=0, vmax=255)
    for mask, colour, label in ((~dynamic, "lime", "static"), (dynamic, "red", "dynamic")):
        for inl, face, rule in ((counts >= N_INLIER, colour, f"N>={N_INLIER}"),
                                (counts < N_INLIER, "none", f"N<{N_INLIER}")):
            sel = mask & inl
            ax.scatter(px[sel, 0], px[sel, 1], s=36, facecolors=face, edgecolors=colour, linewidths=1.2,
                       label=f"{label}, {rule} ({int(sel.sum())})")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_axis_off()
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=6, loc="lower right", framealpha=0.7)
    return save_figure(fig, path)


def plot_weights_and_error(t_gf: np.ndarray, g_f: np.ndarray, t_err: np.ndarray, err: np.ndarray, name: str,
                           path, mean_n: np.ndarray | None = None, delta_label: str = "10 frames"):
    """Top: g_f per frame (and, when given, the mean N of the tracked features on a second axis); bottom: the
    RPE of configuration ``name`` on the same time axis (Fig. 14 without N, Fig. 15 with it)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 4.6), sharex=True)
    top.plot(t_gf, g_f, color="tab:blue", lw=1.0)
    top.set_ylabel("g_f", color="tab:blue")
    top.grid(alpha=0.3)
    if mean_n is not None:
        right = top.twinx()
        right.plot(t_gf, mean_n, color="tab:orange", lw=1.0)
        right.set_ylabel("mean N", color="tab:orange")
    bottom.plot(t_err, err, ".-", color="k", lw=1.0, ms=3)
    bottom.set_ylabel(f"RPE/{delta_label} (m)")
    bottom.set_xlabel("time (s)")
    bottom.grid(alpha=0.3)
    top.set_title(name, fontsize=9)
    return save_figure(fig, path)
