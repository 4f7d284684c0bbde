"""Sweep scaling on this machine: cells per hour with 1 and 2 Dask workers, and worker memory over many cells.

    MUJOCO_GL=egl .venv/bin/python docs/studies/sweep_scaling.py --out /tmp/sweep_scaling [--cells 24] [--memory-cells 100]

Throughput: the same grid (``smoke``, 1 s, klt-pnp, ``scene.texture_richness`` x seeds, ``--cells`` cells) run
from scratch with ``--workers 1`` and ``--workers 2``; cells/hour from the whole ``run_sweep`` wall time
(cluster start included) and in steady state (cells finished after the first, over the time from the first
to the last finish). Memory: ``--memory-cells`` cells on 2 workers; each cell record holds its worker's RSS
(psutil) after the cell, so the first and last RSS of each worker and a least-squares slope per 100 cells
say whether it stays flat (also after the first ``WARM_UP`` cells; ``--cells 0`` runs the memory part
only). Prints a text summary and writes ``summary.json`` into ``--out``.
"""
from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np

from sim.app.sweep.cell import read_record
from sim.app.sweep.driver import run_sweep
from sim.app.sweep.grid import spec_from_cli


def grid_spec(n_cells: int, duration_s: float):
    """``n_cells`` cells: 5 texture levels x enough seeds, cut to ``n_cells``."""
    levels = "0.2,0.4,0.6,0.8,1.0"
    n_seeds = -(-n_cells // 5)
    return spec_from_cli("smoke", (f"scene.texture_richness={levels}",), "klt-pnp", f"0:{n_seeds}",
                         (f"duration_s={duration_s}",))


def run(spec, out: Path, workers: int, n_cells: int) -> dict:
    shutil.rmtree(out, ignore_errors=True)
    summary = run_sweep(spec, out, workers=workers, progress=False, max_cells=n_cells)
    records = [read_record(out, c.key) for c in spec.cells()]
    records = [r for r in records if r is not None]
    ends = np.sort([r["finished_unix_s"] for r in records])
    steady = (len(ends) - 1) / (ends[-1] - ends[0]) * 3600 if len(ends) > 1 and ends[-1] > ends[0] else float("nan")
    return {"workers": workers, "cells": len(records), "wall_s": summary.wall_s,
            "cells_per_hour": len(records) / summary.wall_s * 3600, "steady_cells_per_hour": steady,
            "failed": summary.n_failed, "records": records}


WARM_UP = 5      # a worker's first cells load libraries and grow the allocator's arenas


def slope_per_100(rss) -> float:
    """Least-squares slope of RSS against the cell index, MiB per 100 cells."""
    return float(np.polyfit(np.arange(len(rss)), rss, 1)[0]) * 100 if len(rss) > 2 else float("nan")


def memory(records) -> dict:
    """Per worker: RSS after its first, its WARM_UP-th and its last cell, slopes over all / after warm-up."""
    by_pid = {}
    for r in sorted(records, key=lambda r: r["finished_unix_s"]):
        by_pid.setdefault(r["pid"], []).append(r["rss_mb"])
    out = {}
    for pid, rss in by_pid.items():
        out[str(pid)] = {"cells": len(rss), "first_mb": rss[0], "after_warm_up_mb": rss[min(WARM_UP, len(rss)) - 1],
                         "last_mb": rss[-1], "max_mb": max(rss), "median_mb": float(np.median(rss)),
                         "slope_mb_per_100_cells": slope_per_100(rss),
                         "slope_after_warm_up_mb_per_100_cells": slope_per_100(rss[WARM_UP:]), "rss_mb": rss}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cells", type=int, default=24, help="cells of the throughput runs (0: memory only)")
    ap.add_argument("--memory-cells", type=int, default=100, help="cells of the memory run (0: throughput only)")
    ap.add_argument("--duration", type=float, default=1.0)
    args = ap.parse_args()
    out = Path(args.out)
    result = {}
    if args.cells > 0:
        spec = grid_spec(args.cells, args.duration)
        one, two = (run(spec, out / f"workers{w}", w, args.cells) for w in (1, 2))
        result = {"throughput": [{k: v for k, v in r.items() if k != "records"} for r in (one, two)],
                  "speedup_wall": two["cells_per_hour"] / one["cells_per_hour"],
                  "speedup_steady": two["steady_cells_per_hour"] / one["steady_cells_per_hour"]}
    if args.memory_cells > 0:
        mem_spec = grid_spec(args.memory_cells, args.duration)
        many = run(mem_spec, out / "memory", 2, args.memory_cells)
        result["memory"] = {"cells": many["cells"], "wall_s": many["wall_s"], "per_worker": memory(many["records"])}
    (out / "summary.json").write_text(json.dumps(result, indent=2) + "\n")
    for r in result.get("throughput", []):
        print(f"{r['workers']} worker(s): {r['cells']} cells in {r['wall_s']:.1f} s -> {r['cells_per_hour']:.0f} cells/h "
              f"(steady {r['steady_cells_per_hour']:.0f} cells/h), {r['failed']} failed")
    if "throughput" in result:
        print(f"speed-up 2 vs 1 worker: {result['speedup_wall']:.2f}x wall, {result['speedup_steady']:.2f}x steady")
    for pid, m in result.get("memory", {}).get("per_worker", {}).items():
        print(f"worker {pid}: {m['cells']} cells, RSS first {m['first_mb']:.0f} MiB, after {WARM_UP} cells "
              f"{m['after_warm_up_mb']:.0f} MiB, last {m['last_mb']:.0f} MiB, max {m['max_mb']:.0f} MiB, slope "
              f"{m['slope_mb_per_100_cells']:+.1f} MiB/100 cells ({m['slope_after_warm_up_mb_per_100_cells']:+.1f} "
              f"after the first {WARM_UP})")


if __name__ == "__main__":
    main()
