"""Seed 002 Tables 2/3 over several seeds: run the VINS configurations on each dataset, print the medians.

    vo-testbed generate --scenario urban-dynamic --set imu=euroc-adis16448 --set seed=S --segmentation \\
        --out ROOT/urban-dynamic_sS                      # S = 1..5, also urban-static; no --duration: full route
    OPENBLAS_NUM_THREADS=1 python docs/studies/vins_urban_tables.py ROOT OUT --scenario urban-dynamic \\
        [--seeds 1,2,3,4,5] [--frames N] [--configs vins,vins-ac-gf,...] [--opt key=value ...] \\
        [--plot PNG --plot-seed S]

Each configuration's row is kept in ``OUT/<scenario>_s<seed>/<config>.json`` (``vins_tables.run``); rows
already there are reused, so an interrupted study resumes. The table is ``vins_tables.format_seed_table``.
``--plot``: for seed ``--plot-seed``, the RPE over time of each configuration (seed 002's Fig. 12) above the
true speed and the scale error of ``vins``'s 10-frame motion (estimated / true length - 1, %).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.eval.plots import plt, save_figure
from vins_tables import format_seed_table, run
from vo.vins.tables import RPE_DELTA, TABLE_CONFIGS, rpe_series


def rows_for(dataset: Path, out: Path, frames: int, configs, opts) -> list:
    todo = [c for c in configs if not (out / f"{c}.json").is_file()]
    if todo:
        t0 = time.time()
        run(dataset, out, frames, todo, opts)
        print(f"{dataset.name}: {', '.join(todo)} in {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    return [json.loads((out / f"{c}.json").read_text()) for c in configs]


class _Frame:
    def __init__(self, T, status):
        self.T_o_c0, self.status = T, status


def plot_seed(dataset: Path, out: Path, configs, path: Path) -> None:
    """RPE over time per configuration, true speed and ``vins``'s 10-frame scale error (see module doc)."""
    t_ns = np.asarray(open_dataset(dataset).groundtruth_cam0().t_ns)
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for c in configs:
        z = np.load(out / f"{c}.npz")
        t, e = rpe_series([_Frame(T, s) for T, s in zip(z["T"], z["status"])], z["G"], t_ns)
        ax.plot(t, e, lw=0.8, label=c)
        if c == "vins":
            G, T, ok = z["G"], z["T"], z["status"] != "init"
            d = RPE_DELTA
            lg = np.linalg.norm(G[d:, :3, 3] - G[:-d, :3, 3], axis=1)
            le = np.linalg.norm(T[d:, :3, 3] - T[:-d, :3, 3], axis=1)
            m = ok[:-d] & (lg > 2.0)
            ts = (t_ns[d:len(T)] - t_ns[0]) * 1e-9
            bx.plot(ts[m], 100 * (le[m] / lg[m] - 1), ".", ms=2, color="C0")
            sx = bx.twinx()
            sx.plot(ts, lg / (d * 0.1), color="k", lw=0.8)
            sx.set_ylabel("true speed, m/s")
    ax.set_yscale("log")
    ax.set_ylabel(f"RPE ({RPE_DELTA} frames), m")
    ax.legend(fontsize=7, ncol=3)
    ax.set_title(dataset.name)
    bx.axhline(0, color="grey", lw=0.5)
    bx.set_ylim(-50, 50)
    bx.set_ylabel("vins 10-frame scale error, %")
    bx.set_xlabel("time, s")
    save_figure(fig, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", type=Path, help="folder with <scenario>_s<seed> datasets")
    ap.add_argument("out", type=Path)
    ap.add_argument("--scenario", required=True)
    ap.add_argument("--seeds", default="1,2,3,4,5")
    ap.add_argument("--frames", type=int, default=100000, help="first N frames of each dataset (default: all)")
    ap.add_argument("--configs", default=",".join(TABLE_CONFIGS))
    ap.add_argument("--opt", action="append", default=[], metavar="KEY=VALUE", help="estimator option")
    ap.add_argument("--plot", type=Path, help="PNG: RPE over time, speed and scale error of one seed")
    ap.add_argument("--plot-seed", type=int, default=1)
    a = ap.parse_args(argv)
    opts = {k: parse_value(v, f"--opt {k}", EstimatorError) for k, v in (o.split("=", 1) for o in a.opt)}
    configs = a.configs.split(",")
    runs = {}
    for s in a.seeds.split(","):
        d = a.root / f"{a.scenario}_s{s}"
        if not (d / "metadata.yaml").is_file():
            print(f"error: {d}: no dataset (metadata.yaml missing)", file=sys.stderr)
            return 2
        runs[int(s)] = rows_for(d, a.out / d.name, a.frames, configs, opts)
    print(f"**{a.scenario}**, seeds {a.seeds}\n")
    print(format_seed_table(runs))
    if a.plot:
        d = f"{a.scenario}_s{a.plot_seed}"
        plot_seed(a.root / d, a.out / d, configs, a.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
