"""The sweep driver: farm the cells out on Dask distributed, then build the tables and plots.

By default a :class:`dask.distributed.LocalCluster` of ``workers`` processes with one thread each
(bound to 127.0.0.1, no dashboard); with ``scheduler`` the cells go to an existing cluster (``dask
scheduler`` + ``dask worker``, or dask-jobqueue on Slurm/PBS). Dask is the optional extra
``vo-testbed[sweep]`` and is imported only here. Cells whose record is already in ``DIR/cells`` are
skipped, so an interrupted sweep resumes and a finished one re-runs without work. A record made by other
code (its ``code`` fingerprint differs from the driver's, :mod:`~sim.app.sweep.fingerprint`) is stale:
its cell runs again, unless ``keep_stale``.

Layout of ``DIR``: ``sweep.json`` (the spec and the ``code`` of the run that wrote it),
``cells/<key>.json`` (one record per cell), ``results.{csv,json}``, ``aggregate.{csv,json}``,
``plots/``; ``work/<key>`` holds a dataset being generated and ``datasets/<key>`` the kept ones
(``keep_datasets``).
"""
from __future__ import annotations

import json
import os
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from rigs.atomic_io import atomic_write_json
from sim.app.sweep.cell import RECORD_VERSION, is_done, is_stale, read_record, record_path, run_cell
from sim.app.sweep.fingerprint import code_fingerprint
from sim.app.sweep.grid import SweepError, SweepSpec, parse_seeds
from sim.app.sweep.plots import plot_all
from sim.app.sweep.table import aggregate, tidy_rows, write_tables

INSTALL_HINT = "the sweep needs Dask distributed: pip install 'vo-testbed[sweep]'"
# Dask's statistical profiler samples each worker's task thread every 10 ms and keeps a call tree per
# 1 s cycle for the last 1000 cycles: worker memory grew cell after cell (about +50 MiB per 100 smoke
# cells after warm-up; docs/sweep.md, "Memory per worker"). Sweeps do not use it. Workers started by
# hand take the same setting from the environment: DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False.
WORKER_CONFIG = {"distributed.worker.profile.enabled": False}


@dataclass
class SweepSummary:
    out_dir: Path
    n_cells: int
    n_skipped: int      # already done before this run
    n_run: int
    n_failed: int       # cells with an error (generation or any estimator), this run or before
    wall_s: float
    tables: list
    plots: list
    n_stale: int = 0        # finished cells whose record was made by other code
    n_stale_run: int = 0    # of which run again by this run (0 with keep_stale)
    keep_stale: bool = False
    code: str = ""          # the driver's code fingerprint
    code_counts: dict = field(default_factory=dict)   # fingerprint -> cells, over the records reported


@dataclass
class Report:
    """What :func:`write_report` wrote: table and plot paths, failed cells, cells per code fingerprint."""
    tables: list
    plots: list
    n_failed: int
    code_counts: dict


def import_dask():
    """``(Client, LocalCluster, as_completed)``, or SweepError with the install line."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise SweepError(INSTALL_HINT) from None
    return Client, LocalCluster, as_completed


def run_sweep(spec: SweepSpec, out_dir, workers: int = 1, scheduler=None, keep_datasets: bool = False,
              retry_failed: bool = False, progress: bool = True, max_cells=None,
              keep_stale: bool = False) -> SweepSummary:
    """Run every cell of ``spec`` not yet done (at most ``max_cells`` of them), then write tables and plots.
    A finished cell whose record was made by other code runs again, unless ``keep_stale``."""
    t0 = time.perf_counter()
    cells = spec.cells()                                   # validates every grid value first
    Client, LocalCluster, as_completed = import_dask()
    out_dir = Path(out_dir).expanduser().resolve()        # workers may run in another folder
    code = code_fingerprint()
    _write_spec(out_dir, spec, code)
    records = {c.key: read_record(out_dir, c.key) for c in cells}
    stale = {c.key for c in cells if is_done(records[c.key], spec.estimators, retry_failed)
             and is_stale(records[c.key], code)}
    todo = [c for c in cells
            if not is_done(records[c.key], spec.estimators, retry_failed, code=None if keep_stale else code)]
    n_skipped = len(cells) - len(todo)
    if max_cells is not None:
        todo = todo[:max_cells]
    n_stale_run = 0 if keep_stale else sum(c.key in stale for c in todo)
    if todo:
        note = _stale_note(len(stale), n_stale_run, keep_stale)
        with _client(Client, LocalCluster, workers, scheduler) as client:
            _run_cells(client, as_completed, todo, spec, out_dir, keep_datasets, progress, len(cells), note)
    if (out_dir / "work").is_dir() and not any((out_dir / "work").iterdir()):
        (out_dir / "work").rmdir()
    report = write_report(out_dir, spec, cells)
    return SweepSummary(out_dir, len(cells), n_skipped, len(todo), report.n_failed, time.perf_counter() - t0,
                        report.tables, report.plots, len(stale), n_stale_run, keep_stale, code, report.code_counts)


def _stale_note(n_stale: int, n_stale_run: int, keep_stale: bool) -> str:
    """``"2 stale re-run"`` / ``"2 stale kept"`` (records made by other code), or ``""`` when there are none."""
    if not n_stale:
        return ""
    if keep_stale:
        return f"{n_stale} stale kept"
    return f"{n_stale} stale re-run" if n_stale_run == n_stale else f"{n_stale} stale, {n_stale_run} of them re-run"


def stale_summary(summary: SweepSummary) -> str:
    """The summary's clause on stale records (made by other code than ``summary.code``), or ``""``."""
    note = _stale_note(summary.n_stale, summary.n_stale_run, summary.keep_stale)
    return f", {note} (records made by other code)" if note else ""


def mixed_code_warning(code_counts: dict, current: str = "") -> str:
    """One warning line when the records come from more than one code fingerprint, else ``""``."""
    if len(code_counts) <= 1:
        return ""
    parts = [f"{code or 'no fingerprint'}{' (current)' if code and code == current else ''}: {n} cells"
             for code, n in sorted(code_counts.items(), key=lambda kv: (-kv[1], kv[0]))]
    return (f"warning: the records come from {len(code_counts)} code versions ({', '.join(parts)}); "
            "run the sweep without --keep-stale to re-run the stale ones")


class _client:
    """Context manager: a Client on ``scheduler``, or on a new LocalCluster that it closes afterwards."""

    def __init__(self, Client, LocalCluster, workers, scheduler):
        self.args = Client, LocalCluster, workers, scheduler
        self.cluster = self.client = None

    def __enter__(self):
        Client, LocalCluster, workers, scheduler = self.args
        os.environ.setdefault("MUJOCO_GL", "egl")          # inherited by the worker processes
        if scheduler:
            try:
                self.client = Client(scheduler, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise SweepError(f"--scheduler {scheduler!r}: cannot connect ({exc})") from None
            return self.client
        import dask
        with dask.config.set(WORKER_CONFIG):               # the nannies pass it on to their worker processes
            self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                        dashboard_address=None)
        self.client = Client(self.cluster)
        return self.client

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        return False


def _run_cells(client, as_completed, todo, spec, out_dir, keep_datasets, progress, n_total, note="") -> None:
    from tqdm import tqdm
    futures = {client.submit(run_cell, c, spec.estimators, str(out_dir), keep_datasets, key=f"sweep-cell-{c.key}",
                             pure=False): c for c in todo}
    bar = tqdm(total=n_total, initial=n_total - len(todo), unit="cell", disable=not progress, desc="sweep",
               postfix=note or None)
    try:
        for future in as_completed(futures):
            cell = futures.pop(future)                 # release the result held by the worker
            if future.status != "finished":            # the task itself died (e.g. its worker was killed)
                _record_crash(out_dir, cell, future)
            bar.update(1)
    finally:
        bar.close()


def _record_crash(out_dir, cell, future) -> None:
    try:
        message = f"{type(future.exception()).__name__}: {future.exception()}"
    except Exception as exc:       # noqa: BLE001 - cancelled futures have no exception to fetch
        message = f"{type(exc).__name__}: {exc}"
    atomic_write_json(record_path(out_dir, cell.key),
                      {"version": RECORD_VERSION, "key": cell.key, "code": code_fingerprint(), "seed": cell.seed,
                       "values": dict(cell.values),
                       "error": message.splitlines()[0], "runs": {}}, sort_keys=True)


def _write_spec(out_dir: Path, spec: SweepSpec, code: str) -> None:
    atomic_write_json(out_dir / "sweep.json", {**spec.to_dict(), "code": code})


def load_sweep(out_dir) -> SweepSpec:
    """The spec a sweep in ``out_dir`` was run with (``sweep.json``)."""
    path = Path(out_dir) / "sweep.json"
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise SweepError(f"{path}: not a sweep output folder ({exc})") from None
    return SweepSpec(data["scenario"], tuple((k, tuple(v)) for k, v in data["grid"].items()),
                     tuple(data["estimators"]), parse_seeds(data["seeds"]), tuple(data.get("set", ())))


def write_report(out_dir, spec: SweepSpec, cells=None) -> Report:
    """Tables and plots from the records in ``out_dir`` -> their paths, failed cells, cells per fingerprint."""
    cells = spec.cells() if cells is None else cells
    records = [r for r in (read_record(out_dir, c.key) for c in cells) if r is not None]
    rows = tidy_rows(records, spec.axis_keys, spec.estimators)
    agg = aggregate(rows, spec.axis_keys)
    tables = write_tables(out_dir, rows, agg)
    base = spec.base_config()
    plots = plot_all(out_dir, rows, spec.axis_keys, spec.estimators, float(base.rig.baseline),
                     float(base.rig.cameras[0].fx)) if rows else []
    n_failed = sum(bool(r.get("error") or any(v.get("error") for v in r.get("runs", {}).values())) for r in records)
    return Report(tables, plots, n_failed, dict(Counter(r.get("code") or "" for r in records)))
