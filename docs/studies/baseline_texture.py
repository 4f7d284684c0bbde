"""Analysis of the baseline x texture study (docs/studies/baseline_texture.md) from the sweeps' ``results.csv``.

    .venv/bin/python docs/studies/baseline_texture.py OUT/campus-short OUT/indoor-short [--json FILE]

Prints, as Markdown, per scenario: the drift table (median [q1, q3] over seeds per baseline x texture,
both estimators), the failures and lost frames, the log-log slope of drift against baseline with a
bootstrap confidence interval over seeds, and sign tests of the paired comparisons.

Statistics (every random draw from a seeded numpy Generator):

* The seed of a cell is also its scene seed and its motion seed, so rows with the same seed and texture
  but different baselines share scene and trajectory: comparisons are paired by seed.
* Slope: least-squares fit of ``log(median drift) = a_texture + s log(b)`` (one intercept per texture
  level, one common slope, or one texture level alone), over the baselines of a range. The range-error
  model (seed 001 eq. 7, ``sigma_r = r^2 sigma_p / (b f)``) predicts ``s = -1``. The 95 % interval is a
  percentile bootstrap: the seeds are resampled with replacement (the same draw for every baseline and
  texture, which keeps the pairing), the medians and the fit recomputed, 2000 times.
* Sign tests (scipy ``binomtest``, two-sided, p = 1/2) count in how many seed-paired comparisons one
  side has the lower drift. With 5 pairs the smallest attainable p is 2/32 = 0.0625, so single cells are
  never significant at 5 %; the tests pool the pairs of a scenario.
* The min-max range of 5 seeds is a distribution-free 93.75 % confidence interval of the median
  (1 - 2 * 0.5**5), which is how the per-cell spread should be read.
"""
from __future__ import annotations

import argparse
import json
import math
import warnings
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

from sim.app.sweep.table import read_csv

B_KEY, T_KEY = "baseline", "scene.texture_richness"
N_BOOT = 2000
RANGES = {"all": (0.0, 1.0), "b <= 0.27": (0.0, 0.27), "b >= 0.27": (0.27, 1.0)}


def load(sweep_dir) -> dict:
    """``{(estimator, b, texture, seed): drift or nan, ...}`` plus lost frames and errors of one sweep."""
    rows = read_csv(Path(sweep_dir) / "results.csv")
    drift, lost, errors = {}, {}, {}
    for r in rows:
        k = (r["estimator"], float(r[B_KEY]), float(r[T_KEY]), int(r["seed"]))
        failed = isinstance(r["error"], str) and r["error"] != ""
        drift[k] = np.nan if failed else float(r["drift_pct"])
        lost[k] = 0 if failed else int(r["n_lost"])
        if failed:
            errors[k] = r["error"]
    return {"drift": drift, "lost": lost, "errors": errors, "scenario": Path(sweep_dir).name}


def axes(data) -> tuple:
    ks = data["drift"].keys()
    return tuple(sorted({k[i] for k in ks}, key=lambda v: (str(type(v)), v)) for i in range(4))


def cube(data, estimator) -> np.ndarray:
    """Drift as an array [baseline, texture, seed] for one estimator (NaN where the run failed)."""
    _, bs, ts, seeds = axes(data)
    return np.array([[[data["drift"].get((estimator, b, t, s), np.nan) for s in seeds] for t in ts] for b in bs])


def slope(med: np.ndarray, log_b: np.ndarray) -> float:
    """Common slope of log(median drift) on log(b) with one intercept per column (texture) of ``med``."""
    ok = np.isfinite(med) & (med > 0)
    cols = [j for j in range(med.shape[1]) if ok[:, j].sum() >= 2]
    if not cols:
        return np.nan
    x = np.concatenate([log_b[ok[:, j]] - log_b[ok[:, j]].mean() for j in cols])
    y = np.concatenate([np.log(med[ok[:, j], j]) - np.log(med[ok[:, j], j]).mean() for j in cols])
    return float(x @ y / (x @ x))


def slope_ci(c: np.ndarray, bs, rng: np.random.Generator) -> tuple:
    """(slope, 2.5 %, 97.5 %) of :func:`slope` on the seed medians of ``c`` [b, texture, seed]."""
    log_b = np.log(np.asarray(bs, float))
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)      # all-NaN medians of failed cells
        point = slope(np.nanmedian(c, axis=2), log_b)
        n = c.shape[2]
        boot = [slope(np.nanmedian(c[:, :, rng.integers(0, n, n)], axis=2), log_b) for _ in range(N_BOOT)]
    boot = np.array(boot)
    boot = boot[np.isfinite(boot)]
    lo, hi = np.percentile(boot, [2.5, 97.5]) if boot.size else (np.nan, np.nan)
    return point, float(lo), float(hi)


def sign_test(a: np.ndarray, b: np.ndarray) -> dict:
    """Pairs (a_i, b_i), both finite: how often a < b, and the two-sided sign-test p (ties dropped)."""
    ok = np.isfinite(a) & np.isfinite(b) & (a != b)
    n_less = int((a[ok] < b[ok]).sum())
    n = int(ok.sum())
    p = binomtest(n_less, n, 0.5).pvalue if n else math.nan
    return {"n": n, "a_lower": n_less, "p": float(p)}


def fmt_cell(v: np.ndarray) -> str:
    v = v[np.isfinite(v)]
    if not v.size:
        return "failed"
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return f"{med:.3f} [{q1:.3f}, {q3:.3f}]"


def drift_table(data, estimator) -> list:
    _, bs, ts, _ = axes(data)
    c = cube(data, estimator)
    lines = [f"| texture \\ b (m) | " + " | ".join(f"{b:g}" for b in bs) + " |", "|---" * (len(bs) + 1) + "|"]
    for j, t in enumerate(ts):
        lines.append(f"| {t:g} | " + " | ".join(fmt_cell(c[i, j]) for i in range(len(bs))) + " |")
    return lines


def failures(data) -> list:
    est, bs, ts, seeds = axes(data)
    lines = ["| estimator | runs | failed | runs with lost frames | lost frames (total) | worst cell (b, texture: lost) |",
             "|---|---|---|---|---|---|"]
    for e in est:
        keys = [k for k in data["drift"] if k[0] == e]
        lost = {k: data["lost"][k] for k in keys}
        n_fail = sum(k in data["errors"] for k in keys)
        per_cell = {(b, t): sum(lost[(e, b, t, s)] for s in seeds if (e, b, t, s) in lost) for b in bs for t in ts}
        worst = max(per_cell, key=per_cell.get)
        lines.append(f"| {e} | {len(keys)} | {n_fail} | {sum(v > 0 for v in lost.values())} | {sum(lost.values())} | "
                     f"{worst[0]:g}, {worst[1]:g}: {per_cell[worst]} |")
    for k, msg in sorted(data["errors"].items()):
        lines.append(f"\nfailed: {k[0]} b={k[1]:g} texture={k[2]:g} seed={k[3]}: {msg}")
    return lines


def slopes(data, rng) -> tuple:
    est, bs, ts, _ = axes(data)
    out = {}
    lines = ["| estimator | texture | " + " | ".join(f"slope, {r}" for r in RANGES) + " |",
             "|---|---" + "|---" * len(RANGES) + "|"]
    for e in est:
        c = cube(data, e)
        for label, cols in [("all (pooled)", slice(None))] + [(f"{t:g}", slice(j, j + 1)) for j, t in enumerate(ts)]:
            cells = []
            for rname, (lo, hi) in RANGES.items():
                sel = [i for i, b in enumerate(bs) if lo <= b <= hi]
                s, a, z = slope_ci(c[sel][:, cols], [bs[i] for i in sel], rng)
                out[(e, label, rname)] = (s, a, z)
                cells.append(f"{s:+.2f} [{a:+.2f}, {z:+.2f}]")
            lines.append(f"| {e} | {label} | " + " | ".join(cells) + " |")
    return lines, out


def comparisons(data) -> tuple:
    est, bs, ts, _ = axes(data)
    cubes = {e: cube(data, e) for e in est}
    tests = {}
    if len(est) == 2:
        tests[f"{est[0]} below {est[1]} (all cells, paired by seed)"] = sign_test(cubes[est[0]].ravel(),
                                                                                  cubes[est[1]].ravel())
    for e in est:
        c = cubes[e]
        tests[f"{e}: b={bs[-1]:g} below b={bs[0]:g} (paired by texture, seed)"] = sign_test(c[-1].ravel(), c[0].ravel())
        tests[f"{e}: b={bs[-2]:g} below b={bs[0]:g}"] = sign_test(c[-2].ravel(), c[0].ravel())
        tests[f"{e}: b={bs[-1]:g} below b={bs[-2]:g}"] = sign_test(c[-1].ravel(), c[-2].ravel())
        tests[f"{e}: texture={ts[-1]:g} below texture={ts[0]:g} (paired by b, seed)"] = sign_test(
            c[:, -1].ravel(), c[:, 0].ravel())
    lines = ["| comparison | pairs | first lower | sign-test p |", "|---|---|---|---|"]
    lines += [f"| {name} | {t['n']} | {t['a_lower']} | {t['p']:.2g} |" for name, t in tests.items()]
    return lines, tests


def report(sweep_dirs, seed: int = 0) -> tuple:
    rng = np.random.default_rng(seed)
    md, summary = [], {}
    for d in sweep_dirs:
        data = load(d)
        est = axes(data)[0]
        md += [f"## {data['scenario']}", ""]
        for e in est:
            md += [f"drift % of route, `{e}`: median [q1, q3] over seeds", ""] + drift_table(data, e) + [""]
        md += ["failures and lost frames", ""] + failures(data) + [""]
        sl_lines, sl = slopes(data, rng)
        md += ["log-log slope of median drift against b (95 % bootstrap CI over seeds; 1/b predicts -1)", ""]
        md += sl_lines + [""]
        cmp_lines, tests = comparisons(data)
        md += ["sign tests", ""] + cmp_lines + [""]
        summary[data["scenario"]] = {"slopes": {" | ".join(k): v for k, v in sl.items()}, "tests": tests,
                                     "n_failed": len(data["errors"]), "lost_frames": sum(data["lost"].values())}
    return "\n".join(md), summary


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweeps", nargs="+", help="sweep output folders (each with results.csv)")
    ap.add_argument("--json", help="also write the slopes and tests as JSON here")
    ap.add_argument("--seed", type=int, default=0, help="bootstrap generator seed")
    args = ap.parse_args()
    md, summary = report(args.sweeps, args.seed)
    print(md)
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=2) + "\n")


if __name__ == "__main__":
    main()
