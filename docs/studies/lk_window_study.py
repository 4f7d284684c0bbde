"""How the LK window size changes `rop`'s end-point error (docs/studies/rop_consistency.md, "The LK window").

Usage: .venv/bin/python docs/studies/lk_window_study.py --out DIR [--windows 7,9,11,13,15,21]
       [--supersample 1,3] [--runs 30] [--workers 2] [--scenario campus-short]

For every rendering (``render.supersample``) and LK window (``klt_config.win``: temporal tracking and
stereo matching alike) it runs ``vo-testbed consistency --vary scene`` (the estimator's default
covariance; poses do not depend on it): run k is scene seed 2 + k, image-noise seed 1000 + k, so every
window sees the same 30 scenes and noise. Prints, per setting, the end-point position error over the
runs (camera axes x right, y down, z forward: mean +- standard error, std, rms) and writes
``DIR/lk_window_study.json`` and ``DIR/lk_window_study.png`` (forward bias and spread against the window).
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np


def ints(text: str) -> list:
    return [int(x) for x in text.split(",") if x.strip()]


def study_one(scenario: str, win: int, supersample: int, runs: int, workers: int) -> dict:
    """End-point position error statistics (mm) of one setting."""
    from sim.app.nees import consistency, end_errors
    res = consistency(scenario, "rop", runs=runs, vary="scene", workers=workers, progress=True,
                      options={"klt_config": {"win": win}}, overrides=(f"render.supersample={supersample}",))
    _, pos = end_errors(res.runs_data)
    pos = pos * 1e3
    return dict(win=win, supersample=supersample, runs=len(pos), mean_mm=pos.mean(0).tolist(),
                se_mm=(pos.std(0, ddof=1) / np.sqrt(len(pos))).tolist(), std_mm=pos.std(0, ddof=1).tolist(),
                rms_mm=float(np.sqrt((pos ** 2).sum(1).mean())), distance_m=float(res.distance_m[-1]))


def plot(rows: list, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for k, ss in enumerate(sorted({r["supersample"] for r in rows})):
        sel = sorted((r for r in rows if r["supersample"] == ss), key=lambda r: r["win"])
        w, c = [r["win"] for r in sel], f"C{k}"
        ax[0].errorbar(w, [r["mean_mm"][2] for r in sel], yerr=[2 * r["se_mm"][2] for r in sel], marker="o",
                       capsize=3, color=c, label=f"render.supersample={ss}")
        ax[1].plot(w, [r["std_mm"][2] for r in sel], "o-", color=c, label=f"forward std, supersample={ss}")
        ax[1].plot(w, [r["rms_mm"] for r in sel], "s--", color=c, label=f"rms 3-D error, supersample={ss}")
    ax[0].axhline(0, color="k", lw=0.5)
    ax[0].set(xlabel="LK window (px)", ylabel="run-mean forward end error (mm), +-2 se",
              title="common (scale) error")
    ax[1].set(xlabel="LK window (px)", ylabel="mm", title="spread over the scenes")
    for a in ax:
        a.axvline(21, color="grey", ls=":", lw=1)
        a.legend(fontsize=8)
    fig.suptitle(f"rop end-point error after {rows[0]['distance_m']:.1f} m, {rows[0]['runs']} scenes "
                 "(dotted: seed 003's 21 px)")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--windows", type=ints, default=[7, 9, 11, 13, 15, 21])
    ap.add_argument("--supersample", type=ints, default=[1, 3])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scenario", default="campus-short")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for ss in a.supersample:
        for win in a.windows:
            r = study_one(a.scenario, win, ss, a.runs, a.workers)
            rows.append(r)
            m, se, sd = r["mean_mm"], r["se_mm"], r["std_mm"]
            print(f"supersample {ss} win {win:2d}: end mean x/y/z {m[0]:+.1f} {m[1]:+.1f} {m[2]:+.1f} mm "
                  f"(se {se[0]:.1f} {se[1]:.1f} {se[2]:.1f}), std {sd[0]:.1f} {sd[1]:.1f} {sd[2]:.1f}, "
                  f"rms {r['rms_mm']:.1f} mm", flush=True)
    tmp = a.out / "lk_window_study.json.tmp"
    tmp.write_text(json.dumps(dict(scenario=a.scenario, rows=rows), indent=2))
    os.replace(tmp, a.out / "lk_window_study.json")
    plot(rows, a.out / "lk_window_study.png")


if __name__ == "__main__":
    main()
