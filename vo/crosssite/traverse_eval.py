"""Localize a whole traverse dataset (``vo.dataset.traverse_reader``) and score it against the truth.

Site 0 is taken as known (its true pose); every later site is localized against the previous
site's estimate (:func:`vo.crosssite.localizer.localize_traverse`). Errors are horizontal+vertical
position errors in metres and in % of the distance driven from site 0 (``arc_length_m``);
"per site" is the error of site k, the dead reckoning's and the BA's, against the same truth.
The dead-reckoning NEES uses its own position covariance (body frame, 3 dof).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigs.geometry import inv_T
from rigs.trajectory import Trajectory
from rigs.trajfile import write_tum
from vo.crosssite.figures import matching_figure, traverse_map
from vo.crosssite.localizer import localize_traverse
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.model_check import model_vs_ba
from vo.crosssite.truth import tie_truth_stats
from vo.crosssite.types import SiteResult
from vo.dataset.traverse_reader import read_traverse
from vo.errors import DatasetError


@dataclass(frozen=True)
class TraverseRun:
    """``results`` SiteResult per site 1..n-1; ``T_w_b_est``/``T_w_b_dr``/``T_w_b_true`` (S,4,4);
    ``site_t_ns`` (S,), ``arc_length_m`` (S,), ``cov_dr`` (S,6,6), ``root`` the dataset folder,
    ``sites`` the Site records read."""

    results: tuple
    T_w_b_est: np.ndarray
    T_w_b_dr: np.ndarray
    T_w_b_true: np.ndarray
    cov_dr: np.ndarray
    site_t_ns: np.ndarray
    arc_length_m: np.ndarray
    root: Path
    mode: str
    sites: tuple = ()


def _progress(r: SiteResult) -> None:
    print(f"  site {r.index:2d}: {r.status} ({r.n_tie_points} ties, {r.timings_s.get('total', 0):.0f} s)", flush=True)


def dataset_root(path) -> Path:
    """``path`` as a Path; a one-line error when it holds no ``metadata.yaml``."""
    root = Path(path)
    if not (root / "metadata.yaml").is_file():
        raise DatasetError(f"{root}: not a dataset folder (no metadata.yaml)")
    return root


def localize_dataset(path, cfg: CrossSiteConfig = CrossSiteConfig(), max_sites: int = 0,
                     progress: bool = False) -> TraverseRun:
    """Read the traverse at ``path`` (first ``max_sites`` sites if > 0) and localize every site, with
    OpenCV on one thread (the stages are many small calls; threads only contend on a shared machine)."""
    import cv2
    cv2.setNumThreads(1)
    root = dataset_root(path)
    tr = read_traverse(root, max_sites=max_sites)
    if len(tr.sites) < 2:
        raise DatasetError(f"{root}: a traverse needs at least 2 sites, got {len(tr.sites)}")
    results = localize_traverse(tr.sites, tr.T_w_b_true[0], cfg, _progress if progress else None)
    T_est = np.array([tr.T_w_b_true[0]] + [r.T_w_b for r in results])
    return TraverseRun(tuple(results), T_est, np.array([s.T_w_b_prior for s in tr.sites]), tr.T_w_b_true,
                       np.array([s.cov_prior for s in tr.sites]), tr.site_t_ns, tr.arc_length_m, root, cfg.mode,
                       tuple(tr.sites))


def site_table(run: TraverseRun) -> list:
    """One dict per site: distance, DR and BA position error (m, % of distance), DR NEES, status,
    tie points, time (s)."""
    rows = []
    for k in range(len(run.site_t_ns)):
        d = float(run.arc_length_m[k])
        e_dr = run.T_w_b_true[k, :3, 3] - run.T_w_b_dr[k, :3, 3]
        e_ba = float(np.linalg.norm(run.T_w_b_true[k, :3, 3] - run.T_w_b_est[k, :3, 3]))
        e_b = run.T_w_b_dr[k, :3, :3].T @ e_dr
        C = run.cov_dr[k][3:, 3:]
        nees = float(e_b @ np.linalg.solve(C, e_b)) if k > 0 else float("nan")
        r: SiteResult = run.results[k - 1] if k > 0 else None
        pct = (lambda e: 100.0 * e / d if d > 0 else float("nan"))
        leg = _leg_errors(run, k)
        rows.append({"site": k, "distance_m": round(d, 3), "dr_err_m": round(float(np.linalg.norm(e_dr)), 4),
                     "dr_err_pct": round(pct(np.linalg.norm(e_dr)), 3), "dr_sigma_m": round(float(np.sqrt(np.trace(C))), 4),
                     "dr_nees": round(nees, 3), "ba_err_m": round(e_ba, 4), "ba_err_pct": round(pct(e_ba), 3),
                     "ba_sigma_m": round(float(np.sqrt(np.trace(r.cov[3:, 3:]))), 4) if r else 0.0,
                     **leg, "status": r.status if r else "known", "tie_points": r.n_tie_points if r else 0,
                     "time_s": round(float(r.timings_s.get("total", 0.0)), 2) if r else 0.0,
                     "stats": r.stats if r else {}, "truth": _truth(run, k, r), "timings_s": {k2: round(v, 3) for k2, v in r.timings_s.items()} if r else {},
                     "reason": r.reason if r else ""})
    return rows


def _leg_errors(run: TraverseRun, k: int) -> dict:
    """Error of the leg k-1 -> k alone (the relative motion's translation) in % of its true length,
    for the dead reckoning and the BA."""
    if k == 0:
        return {"leg_m": 0.0, "dr_leg_err_pct": float("nan"), "ba_leg_err_pct": float("nan")}
    rel = lambda T: (inv_T(T[k - 1]) @ T[k])[:3, 3]  # noqa: E731
    t_true = rel(run.T_w_b_true)
    L = float(np.linalg.norm(t_true))
    pct = lambda T: round(100.0 * float(np.linalg.norm(rel(T) - t_true)) / L, 3) if L > 0 else float("nan")  # noqa: E731
    return {"leg_m": round(L, 3), "dr_leg_err_pct": pct(run.T_w_b_dr), "ba_leg_err_pct": pct(run.T_w_b_est)}


def _truth(run: TraverseRun, k: int, r) -> dict:
    """True-tie counts of site pair k-1 -> k (:mod:`vo.crosssite.truth`); {} without records."""
    if r is None or r.ties is None or len(run.sites) <= k:
        return {}
    return tie_truth_stats(run.sites[k - 1], run.sites[k], r.ties, run.T_w_b_true[k - 1], run.T_w_b_true[k])


def summary(run: TraverseRun, rows: list) -> dict:
    """Whole-traverse figures: mean per-site % (sites 1..), final % and the DR mean NEES (3 dof)."""
    later = rows[1:]
    mean = lambda key: round(float(np.nanmean([r[key] for r in later])), 3)
    return {"dataset": str(run.root), "method": "crosssite", "mode": run.mode, "n_sites": len(rows),
            "distance_m": rows[-1]["distance_m"], "dr_mean_err_pct": mean("dr_err_pct"),
            "ba_mean_err_pct": mean("ba_err_pct"), "dr_mean_leg_err_pct": mean("dr_leg_err_pct"),
            "ba_mean_leg_err_pct": mean("ba_leg_err_pct"), "dr_final_err_pct": rows[-1]["dr_err_pct"],
            "ba_final_err_pct": rows[-1]["ba_err_pct"], "dr_mean_nees_3dof": mean("dr_nees"),
            "n_ok": sum(r["status"] == "ok" for r in later), "sites": rows}


def format_table(rows: list) -> str:
    """Per site: distance, cumulative DR/BA error (m, % of distance), leg DR/BA error (% of leg)."""
    head = (f"{'site':>4} {'dist m':>7} {'DR err m':>9} {'DR %':>6} {'BA err m':>9} {'BA %':>6} {'DR leg%':>7} "
            f"{'BA leg%':>7} {'status':>14} {'ties':>5} {'time s':>7}")
    lines = [head]
    for r in rows:
        lines.append(f"{r['site']:>4} {r['distance_m']:>7.2f} {r['dr_err_m']:>9.3f} {r['dr_err_pct']:>6.2f} "
                     f"{r['ba_err_m']:>9.3f} {r['ba_err_pct']:>6.2f} {r['dr_leg_err_pct']:>7.2f} {r['ba_leg_err_pct']:>7.2f} "
                     f"{r['status']:>14} {r['tie_points']:>5} {r['time_s']:>7.1f}")
    return "\n".join(lines)


def write_outputs(run: TraverseRun, out) -> dict:
    """Write ``site_poses_tum.txt`` (T_w_b per site at the site times), ``summary.json``,
    ``traverse_map.png`` and ``matching.png``; -> the summary dict (with the file paths)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_tum(out / "site_poses_tum.txt", Trajectory(np.asarray(run.site_t_ns, np.int64), run.T_w_b_est, ref="w", frame="b"))
    rows = site_table(run)
    s = summary(run, rows)
    s["model_vs_ba"] = model_vs_ba(run, run.sites)
    traverse_map(run, out / "traverse_map.png")
    s["files"] = {"poses": str(out / "site_poses_tum.txt"), "map": str(out / "traverse_map.png")}
    pair = matching_figure(run, out / "matching.png")
    if pair is not None:
        s["files"]["matching"] = str(out / "matching.png")
    (out / "summary.json").write_text(json.dumps(s, indent=1, default=float))
    return s


def run_and_write(path, out, cfg: CrossSiteConfig = CrossSiteConfig(), max_sites: int = 0, progress: bool = False) -> dict:
    """:func:`localize_dataset` then :func:`write_outputs`; adds the wall time."""
    t0 = time.perf_counter()
    run = localize_dataset(path, cfg, max_sites, progress)
    s = write_outputs(run, out)
    s["wall_s"] = round(time.perf_counter() - t0, 1)
    return s


def timing_table(rows: list) -> str:
    """Per site pair: total and per-stage seconds (stage names as the localizer records them)."""
    stages = sorted({k for r in rows for k in r["timings_s"] if k not in ("total", "cpu_total")}) + ["cpu_total"]
    lines = [f"{'pair':>7} {'status':>14} {'ties':>5} {'total s':>8} " + " ".join(f"{s[:10]:>10}" for s in stages)]
    for r in rows:
        t = r["timings_s"]
        lines.append(f"{r['site'] - 1:>3}->{r['site']:<3} {r['status']:>14} {r['tie_points']:>5} {r['time_s']:>8.1f} "
                     + " ".join(f"{t.get(s, float('nan')):>10.2f}" for s in stages))
    if rows:
        cpu = [r["timings_s"].get("cpu_total", float("nan")) for r in rows]
        lines.append(f"mean {np.mean([r['time_s'] for r in rows]):.1f} s wall ({np.mean(cpu):.1f} s CPU), "
                     f"max {max(r['time_s'] for r in rows):.1f} s wall per pair")
    return "\n".join(lines)
