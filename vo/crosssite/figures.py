"""Figures of a localized traverse, as seed 001 Fig. 5 (traverse map) and Fig. 4 (matching).

The map is drawn over the dataset's ``map.png`` (the writer's hill-shaded top-down orthoimage with
the true route) in a second panel, and re-draws the true, dead-reckoning and BA site tracks with
site numbers in metric axes in the first (the PNG carries no georeference, so the tracks are not
overlaid on it).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def traverse_map(run, path) -> Path:
    """True, dead-reckoning and cross-site BA site positions (x east, y north) with site numbers."""
    from vo.eval.plots import save_figure
    plt = _plt()
    ortho = Path(run.root) / "map.png"
    fig, axes = plt.subplots(1, 2 if ortho.is_file() else 1, figsize=(15 if ortho.is_file() else 8, 7.5), squeeze=False)
    ax = axes[0, 0]
    for T, style, label in ((run.T_w_b_true, "g-o", "truth"), (run.T_w_b_dr, "r--^", "dead reckoning"),
                            (run.T_w_b_est, "b-s", f"cross-site BA ({run.mode})")):
        ax.plot(T[:, 0, 3], T[:, 1, 3], style, ms=4, lw=1, label=label)
    for k, T in enumerate(run.T_w_b_true):
        ax.annotate(str(k), T[:2, 3], xytext=(4, 4), textcoords="offset points", fontsize=8)
    xy = np.vstack([run.T_w_b_true[:, :2, 3], run.T_w_b_dr[:, :2, 3], run.T_w_b_est[:, :2, 3]])
    c, half = 0.5 * (xy.min(axis=0) + xy.max(axis=0)), 0.5 * float(np.ptp(xy, axis=0).max()) + 5.0
    ax.set_xlim(c[0] - half, c[0] + half)
    ax.set_ylim(c[1] - half, c[1] + half)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("site positions")
    if ortho.is_file():
        axes[0, 1].imshow(plt.imread(str(ortho)))
        axes[0, 1].set_axis_off()
        axes[0, 1].set_title("dataset map.png (orthoimage, true route)")
    return save_figure(fig, str(path))


def _best_pair(run):
    """(site index, (i, j)) of the localized site and pan-pair combination with most tie points."""
    best = None
    for r in run.results:
        t = r.ties
        if t is None or t.inlier is None or not len(t.inlier):
            continue
        for key in t.boxes:
            s = (t.pair_prev == key[0]) & (t.pair_cur == key[1]) & t.inlier
            if best is None or s.sum() > best[0]:
                best = (int(s.sum()), r, key)
    return best


def matching_figure(run, path):
    """Previous and current left images of the best pan pair: predicted regions (dashed boxes),
    candidate ASIFT ties (small dots) and the tie points kept by the outlier test (crosses).
    -> (site, (i, j)) drawn, or None when no site has tie points."""
    from vo.eval.plots import save_figure
    best = _best_pair(run)
    if best is None:
        return None
    _, r, (i, j) = best
    prev, cur, t = run.sites[r.index - 1], run.sites[r.index], r.ties
    plt = _plt()
    from matplotlib.patches import Rectangle
    fig, axes = plt.subplots(1, 2, figsize=(14, 7))
    sel = (t.pair_prev == i) & (t.pair_cur == j)
    for ax, img, uv, box, title in ((axes[0], prev.pairs[i].left, t.uv_prev, t.boxes[(i, j)][0], f"site {r.index - 1} pair {i}"),
                                    (axes[1], cur.pairs[j].left, t.uv_cur, t.boxes[(i, j)][1], f"site {r.index} pair {j}")):
        ax.imshow(img, cmap="gray")
        if box is not None:
            ax.add_patch(Rectangle((box[0], box[1]), box[2] - box[0], box[3] - box[1], fill=False, ls="--", ec="yellow", lw=1.5))
        ax.plot(uv[sel, 0], uv[sel, 1], ".", color="orange", ms=2, label="candidates (SIFT/ASIFT on the zoomed image)")
        ax.plot(uv[sel & t.inlier, 0], uv[sel & t.inlier, 1], "c+", ms=6, label="tie points (eq. 2 inliers)")
        ax.set_title(title)
        ax.set_axis_off()
    axes[0].legend(loc="lower left", fontsize=8)
    save_figure(fig, str(path))
    return r.index, (i, j)
