"""Sweep results: the tidy table (one row per cell x estimator) and its aggregate over seeds.

Tidy columns: ``key``, ``seed``, the grid axes (one column each, named by the axis key),
``estimator``, ``error`` (empty when the run succeeded), the metrics :data:`METRICS` and ``code`` (the
fingerprint of the code that ran the cell, :mod:`~sim.app.sweep.fingerprint`). The
aggregate has one row per grid point x estimator with ``n_ok`` / ``n_failed`` seeds and, for each
metric, the median, the quartiles (``_q1``/``_q3``) and the min/max over the successful seeds.
Written as CSV and JSON (Parquet too when pyarrow is installed).
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from rigs.atomic_io import atomic_write, atomic_write_json, atomic_write_text

METRICS = ("drift_pct", "ate_rmse_m", "rpe_trans_rmse_m", "rpe_rot_rmse_deg", "n_lost", "n_frames", "ms_per_frame",
           "end_diff_m", "path_length_m")
AGG_METRICS = ("drift_pct", "ate_rmse_m", "rpe_trans_rmse_m", "n_lost", "ms_per_frame")
# figures that depend only on the configuration (not on the machine's speed): identical between runs
DETERMINISTIC = ("drift_pct", "ate_rmse_m", "rpe_trans_rmse_m", "rpe_rot_rmse_deg", "n_lost", "n_frames",
                 "end_diff_m", "path_length_m")


def tidy_rows(records, axis_keys, estimators) -> list:
    """Cell records -> rows (dicts), sorted by grid values, estimator, seed."""
    rows = []
    for rec in records:
        for name in estimators:
            run = rec.get("runs", {}).get(name) or {}
            error = rec.get("error") or run.get("error") or ("" if run else "not run")
            row = {"key": rec["key"], "seed": rec["seed"], **{k: rec["values"].get(k) for k in axis_keys},
                   "estimator": name, "error": error or ""}
            row.update({m: (np.nan if error else run.get(m, np.nan)) for m in METRICS})
            row["code"] = rec.get("code") or ""
            rows.append(row)
    order = {name: i for i, name in enumerate(estimators)}
    return sorted(rows, key=lambda r: (tuple(sort_key(r[k]) for k in axis_keys), order[r["estimator"]], r["seed"]))


def sort_key(v):
    return (0, float(v), "") if isinstance(v, (int, float)) and not isinstance(v, bool) else (1, 0.0, str(v))


def aggregate(rows, axis_keys) -> list:
    """Median, quartiles and min/max over seeds per grid point x estimator."""
    groups = {}
    for r in rows:
        groups.setdefault((tuple(_hashable(r[k]) for k in axis_keys), r["estimator"]), []).append(r)
    out = []
    for (_, name), members in groups.items():
        ok = [r for r in members if not r["error"]]
        agg = {**{k: members[0][k] for k in axis_keys}, "estimator": name, "n_ok": len(ok),
               "n_failed": len(members) - len(ok)}
        for m in AGG_METRICS:
            v = np.array([r[m] for r in ok], dtype=float)
            v = v[np.isfinite(v)]
            stats = np.percentile(v, [0, 25, 50, 75, 100]) if v.size else [np.nan] * 5
            for suffix, x in zip(("min", "q1", "median", "q3", "max"), stats):
                agg[f"{m}_{suffix}"] = float(x)
        out.append(agg)
    return out


def _hashable(v):
    return json.dumps(v, sort_keys=True, default=str)


def write_tables(out_dir, rows, agg) -> list:
    """Write ``results.{csv,json}`` and ``aggregate.{csv,json}`` (and ``.parquet`` with pyarrow) -> paths."""
    out_dir = Path(out_dir)
    paths = []
    for name, table in (("results", rows), ("aggregate", agg)):
        paths.append(atomic_write_text(out_dir / f"{name}.csv", to_csv(table)))
        paths.append(atomic_write_json(out_dir / f"{name}.json", [_json_row(r) for r in table]))
        parquet = _write_parquet(out_dir / f"{name}.parquet", table)
        if parquet:
            paths.append(parquet)
    return paths


def to_csv(table) -> str:
    if not table:
        return ""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(table[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows([{k: ("" if _isnan(v) else v) for k, v in r.items()} for r in table])
    return buf.getvalue()


TEXT_COLUMNS = ("key", "code", "estimator", "error")     # hex digests such as "12e4..." stay text


def read_csv(path) -> list:
    """Rows of a table written by :func:`to_csv` (numbers parsed, empty cells NaN, :data:`TEXT_COLUMNS` kept)."""
    with open(path, newline="") as f:
        return [{k: (v if k in TEXT_COLUMNS else _parse(v)) for k, v in r.items()} for r in csv.DictReader(f)]


def _parse(text: str):
    if text == "":
        return np.nan
    try:
        return int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return text


def _isnan(v) -> bool:
    return isinstance(v, float) and np.isnan(v)


def _json_row(r: dict) -> dict:
    return {k: (None if _isnan(v) else v) for k, v in r.items()}


def _write_parquet(path: Path, table):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return None
    columns = {k: [r[k] for r in table] for k in (table[0] if table else {})}
    return atomic_write(path, lambda tmp: pq.write_table(pa.table(columns), tmp))


def format_aggregate(agg, axis_keys, metric: str = "drift_pct") -> str:
    """Plain-text aggregate: grid values, estimator, median [q1, q3] of ``metric``, seeds ok/failed."""
    w = max([len("estimator")] + [len(str(a["estimator"])) for a in agg]) + 2
    head = "".join(f"{k:>24}" for k in axis_keys) + f"{'estimator':>{w}}{'median ' + metric:>20}{'IQR':>22}{'ok/fail':>9}"
    lines = [head]
    for a in agg:
        lines.append("".join(f"{str(a[k]):>24}" for k in axis_keys) + f"{a['estimator']:>{w}}"
                     f"{a[metric + '_median']:20.4g}   [{a[metric + '_q1']:8.4g}, {a[metric + '_q3']:8.4g}]"
                     f"{a['n_ok']:>5}/{a['n_failed']}")
    return "\n".join(lines)
