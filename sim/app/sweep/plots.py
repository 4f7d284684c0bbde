"""Sweep plots (matplotlib, Agg) from the tidy rows of :mod:`sim.app.sweep.table`.

* ``heatmap_<estimator>.png``: axis 1 x axis 2 -> median drift over seeds (and over any further axes);
* ``lines_<axis>.png``: median drift against each axis, one panel per estimator, one line per value
  of the second axis, the seed spread (interquartile range) as a band;
* ``baseline_prediction.png`` (when an axis is ``baseline`` / ``rig.baseline``): measured median drift
  against baseline beside the range-error model of seed 001 eq. 7 (``sigma_r = r^2 sigma_p / (b f)``,
  so at a fixed range, focal length and parallax error drift scales as 1/b), scaled to the measured
  median at the reference baseline (the scenario's own baseline when on the grid, else the largest).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from sim.app.sweep.table import sort_key
from vo.errorprop.range import range_sigma

BASELINE_KEYS = ("baseline", "rig.baseline")


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path) -> Path:
    from vo.eval.plots import save_figure
    return save_figure(fig, path)


def _values(rows, key) -> list:
    return sorted({r[key] for r in rows}, key=sort_key)


def _stats(rows, metric="drift_pct", **where):
    """(q1, median, q3) of ``metric`` over the successful rows matching ``where``."""
    v = np.array([r[metric] for r in rows if not r["error"] and all(r[k] == x for k, x in where.items())], float)
    v = v[np.isfinite(v)]
    return tuple(np.percentile(v, [25, 50, 75])) if v.size else (np.nan,) * 3


def plot_all(out_dir, rows, axis_keys, estimators, reference_baseline=None, fx_px: float = 458.0) -> list:
    """Draw every plot into ``out_dir/plots`` -> paths written."""
    plots = Path(out_dir) / "plots"
    paths = []
    if len(axis_keys) >= 2:
        paths += [heatmap(rows, axis_keys[0], axis_keys[1], name, plots / f"heatmap_{name}.png", axis_keys[2:])
                  for name in estimators]
    for key in axis_keys:
        other = next((k for k in axis_keys if k != key), None)
        paths.append(lines(rows, key, other, estimators, plots / f"lines_{key}.png"))
    base = next((k for k in axis_keys if k in BASELINE_KEYS), None)
    if base is not None:
        paths.append(baseline_prediction(rows, base, estimators, plots / "baseline_prediction.png",
                                         reference_baseline, fx_px))
    return paths


def heatmap(rows, key_x, key_y, estimator, path, others=()) -> Path:
    plt = _plt()
    xs, ys = _values(rows, key_x), _values(rows, key_y)
    sub = [r for r in rows if r["estimator"] == estimator]
    grid = np.array([[_stats(sub, **{key_x: x, key_y: y})[1] for x in xs] for y in ys])
    fig, ax = plt.subplots(figsize=(1.2 * len(xs) + 3, 0.8 * len(ys) + 2.5))
    im = ax.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
    for (j, i), v in np.ndenumerate(grid):
        ax.text(i, j, "failed" if np.isnan(v) else f"{v:.3g}", ha="center", va="center", color="w", fontsize=8)
    ax.set_xticks(range(len(xs)), [str(x) for x in xs])
    ax.set_yticks(range(len(ys)), [str(y) for y in ys])
    ax.set_xlabel(key_x)
    ax.set_ylabel(key_y)
    ax.set_title(f"{estimator}: median drift % over seeds" + (f" and {', '.join(others)}" if others else ""))
    fig.colorbar(im, ax=ax, label="drift %")
    return _save(fig, path)


def lines(rows, key, other, estimators, path) -> Path:
    plt = _plt()
    xs = _values(rows, key)
    numeric = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in xs)
    pos = np.array(xs, float) if numeric else np.arange(len(xs))
    fig, axes = plt.subplots(1, len(estimators), figsize=(5 * len(estimators), 4), squeeze=False, sharey=True)
    for ax, name in zip(axes[0], estimators):
        sub = [r for r in rows if r["estimator"] == name]
        for level in (_values(rows, other) if other else [None]):
            where = {other: level} if other else {}
            q = np.array([_stats(sub, **{key: x}, **where) for x in xs])
            line, = ax.plot(pos, q[:, 1], "o-", label=f"{other}={level}" if other else "median")
            ax.fill_between(pos, q[:, 0], q[:, 2], color=line.get_color(), alpha=0.2)
        ax.set_title(f"{name}: median drift, band = IQR over seeds")
        ax.set_xlabel(key)
        if not numeric:
            ax.set_xticks(pos, [str(x) for x in xs])
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("drift %")
    return _save(fig, path)


def predicted_drift(baselines, b_ref: float, drift_ref: float, fx_px: float, range_m: float = 10.0,
                    sigma_p_px: float = 1.0 / 3.0) -> np.ndarray:
    """Seed 001 eq. 7 range error at ``baselines`` relative to ``b_ref``, times the measured ``drift_ref``:
    ``drift_ref * sigma_r(b) / sigma_r(b_ref)`` (= ``drift_ref * b_ref / b``; range, f and sigma_p cancel)."""
    b = np.asarray(baselines, float)
    sig = np.array([range_sigma(range_m, bi, fx_px, sigma_p_px) for bi in b])
    return drift_ref * sig / range_sigma(range_m, b_ref, fx_px, sigma_p_px)


def baseline_prediction(rows, key, estimators, path, reference_baseline=None, fx_px: float = 458.0) -> Path:
    plt = _plt()
    bs = np.array(_values(rows, key), float)
    b_ref = reference_baseline if reference_baseline in bs else float(bs.max())
    dense = np.linspace(bs.min(), bs.max(), 200)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for name in estimators:
        sub = [r for r in rows if r["estimator"] == name]
        q = np.array([_stats(sub, **{key: b}) for b in _values(rows, key)])
        line = ax.errorbar(bs, q[:, 1], yerr=[q[:, 1] - q[:, 0], q[:, 2] - q[:, 1]], fmt="o", capsize=3,
                           label=f"{name} measured (median, IQR)")
        ref = q[list(bs).index(b_ref), 1]
        if np.isfinite(ref):
            ax.plot(dense, predicted_drift(dense, b_ref, ref, fx_px), "--", color=line[0].get_color(),
                    label=f"{name} eq. 7 model (1/b)")
    ax.set_xlabel("stereo baseline b (m)")
    ax.set_ylabel("drift %")
    ax.set_title(f"range-error model (seed 001 eq. 7) scaled to the median at b = {b_ref:g} m", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, path)
