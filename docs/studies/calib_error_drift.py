"""Drift against calibration-error magnitude (docs/sensor_effects.md, "Calibration error against drift").

    .venv/bin/python docs/studies/calib_error_drift.py SWEEP_DIR [SWEEP_DIR ...] --png docs/studies/figures/calib_error/calib_error_drift.png

Each SWEEP_DIR is a ``vo-testbed sweep`` with one grid axis ``calib_error.<field>`` (e.g.
``--grid calib_error.focal_ppm=0,500,1000,2000,5000``). One panel per sweep: median drift over the
seeds against the magnitude, one line per estimator, the interquartile range as a band (magnitude 0
drawn at the left edge of a symmetric-log axis). Prints the table (median [q1, q3], lost frames) as Markdown.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sim.app.sweep.table import read_csv


def load(sweep_dir) -> tuple:
    """(axis key, rows) of a one-axis calibration-error sweep."""
    rows = read_csv(Path(sweep_dir) / "results.csv")
    keys = [k for k in rows[0] if k.startswith("calib_error.")]
    if len(keys) != 1:
        raise SystemExit(f"{sweep_dir}: expected one calib_error.* grid axis, found {keys}")
    return keys[0], rows


def stats(rows, key, estimator) -> list:
    """Per magnitude: (magnitude, q1, median, q3, n ok, n failed, lost frames) of drift over seeds."""
    out = []
    for m in sorted({float(r[key]) for r in rows}):
        sub = [r for r in rows if float(r[key]) == m and r["estimator"] == estimator]
        ok = [r for r in sub if not (isinstance(r["error"], str) and r["error"])]
        d = np.array([r["drift_pct"] for r in ok], float)
        q = np.percentile(d, [25, 50, 75]) if d.size else [np.nan] * 3
        out.append((m, *q, len(ok), len(sub) - len(ok), int(sum(r["n_lost"] for r in ok))))
    return out


def table(key, rows, estimators) -> list:
    lines = [f"| `{key}` | " + " | ".join(f"{e} drift % median [q1, q3] (lost frames)" for e in estimators) + " |",
             "|---" * (len(estimators) + 1) + "|"]
    per = {e: stats(rows, key, e) for e in estimators}
    for i, s in enumerate(per[estimators[0]]):
        cells = []
        for e in estimators:
            m, q1, med, q3, n_ok, n_fail, lost = per[e][i]
            cells.append("failed" if not n_ok else f"{med:.2f} [{q1:.2f}, {q3:.2f}] ({lost})"
                         + (f", {n_fail} failed" if n_fail else ""))
        lines.append(f"| {s[0]:g} | " + " | ".join(cells) + " |")
    return lines


def plot(sweeps, png) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(sweeps), figsize=(5.2 * len(sweeps), 4), squeeze=False)
    for ax, (key, rows, estimators) in zip(axes[0], sweeps):
        for e in estimators:
            s = np.array(stats(rows, key, e), float)
            line, = ax.plot(s[:, 0], s[:, 2], "o-", label=f"{e} (median)")
            ax.fill_between(s[:, 0], s[:, 1], s[:, 3], color=line.get_color(), alpha=0.2)
        nonzero = sorted(v for v in {float(r[key]) for r in rows} if v > 0)
        ax.set_xscale("symlog", linthresh=nonzero[0] if nonzero else 1.0)
        ax.set_yscale("log")
        ax.set_xlabel(key)
        ax.set_title(f"campus-short: drift vs {key.split('.', 1)[1]}\nband = IQR over seeds", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("end-point drift % of route")
    fig.tight_layout()
    fig.savefig(png, dpi=80)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweeps", nargs="+")
    ap.add_argument("--png", help="write the figure here")
    args = ap.parse_args()
    sweeps = []
    for d in args.sweeps:
        key, rows = load(d)
        estimators = list(dict.fromkeys(r["estimator"] for r in rows))
        sweeps.append((key, rows, estimators))
        print("\n".join(table(key, rows, estimators)) + "\n")
    if args.png:
        plot(sweeps, args.png)


if __name__ == "__main__":
    main()
