"""Seed 002 Tables 2/3 over several seeds: run the VINS configurations on each dataset, print the medians.

    vo-testbed generate --scenario urban-dynamic --set imu=euroc-adis16448 --set seed=S --segmentation \\
        --out ROOT/urban-dynamic_sS                      # S = 1..5, also urban-static; no --duration: full route
    OPENBLAS_NUM_THREADS=1 python docs/studies/vins_urban_tables.py ROOT OUT --scenario urban-dynamic \\
        [--seeds 1,2,3,4,5] [--frames N] [--configs vins,vins-ac-gf,...] [--opt key=value ...]

Each configuration's row is kept in ``OUT/<scenario>_s<seed>/<config>.json`` (``vo.vins.tables.run``); rows
already there are reused, so an interrupted study resumes. The table is ``vo.vins.tables.format_seed_table``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import yaml

from vo.vins.tables import TABLE_CONFIGS, format_seed_table, run


def rows_for(dataset: Path, out: Path, frames: int, configs, opts) -> list:
    todo = [c for c in configs if not (out / f"{c}.json").is_file()]
    if todo:
        t0 = time.time()
        run(dataset, out, frames, todo, opts)
        print(f"{dataset.name}: {', '.join(todo)} in {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    return [json.loads((out / f"{c}.json").read_text()) for c in configs]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", type=Path, help="folder with <scenario>_s<seed> datasets")
    ap.add_argument("out", type=Path)
    ap.add_argument("--scenario", required=True)
    ap.add_argument("--seeds", default="1,2,3,4,5")
    ap.add_argument("--frames", type=int, default=100000, help="first N frames of each dataset (default: all)")
    ap.add_argument("--configs", default=",".join(TABLE_CONFIGS))
    ap.add_argument("--opt", action="append", default=[], metavar="KEY=VALUE", help="estimator option")
    a = ap.parse_args(argv)
    opts = {k: yaml.safe_load(v) for k, v in (o.split("=", 1) for o in a.opt)}
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
