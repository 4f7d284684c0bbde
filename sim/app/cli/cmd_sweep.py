"""``vo-testbed sweep``: run a grid of configurations x seeds x estimators on Dask; ``sweep report DIR`` redraws."""
from __future__ import annotations

import sys

import click

from sim.app.cli.options import echo_json, json_option, set_option


@click.group("sweep", invoke_without_command=True)
@click.option("--scenario", default=None, help="Named scenario (default campus-short, or the spec file's).")
@click.option("--grid", "grid", multiple=True, metavar="KEY=V1,V2,...",
              help="A grid axis: any --set key and its values, e.g. baseline=0.063,0.12 or scene.texture_richness=0.1,1.")
@click.option("--spec", "spec_file", type=click.Path(exists=True, dir_okay=False),
              help="YAML sweep spec (keys scenario, grid, estimators, seeds, set) instead of --grid.")
@click.option("--estimator", "estimators", multiple=True, metavar="NAME[,NAME]",
              help="Estimators run on every cell (comma-separated or repeated; default rop).")
@click.option("--seeds", default=None, help="'start:stop' (stop excluded) or '0,3,7'; default 0:1.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), help="Output folder (resumed when it exists).")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Worker processes of the local Dask cluster (one thread each).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on an existing Dask cluster, e.g. tcp://127.0.0.1:8786 (--workers is then ignored).")
@click.option("--keep-datasets", is_flag=True, help="Keep each cell's dataset in OUT/datasets/<key>.")
@click.option("--retry-failed", is_flag=True, help="Run again the cells recorded as failed.")
@click.option("--keep-stale", is_flag=True,
              help="Keep finished cells whose record was made by other code (another code fingerprint) "
                   "instead of running them again.")
@click.option("--max-cells", type=click.IntRange(min=1), default=None, help="Run at most N of the cells not done.")
@click.option("--no-progress", is_flag=True)
@set_option
@json_option
@click.pass_context
def sweep(ctx, scenario, grid, spec_file, estimators, seeds, out_dir, workers, scheduler, keep_datasets,
          retry_failed, keep_stale, max_cells, no_progress, overrides, as_json):
    """Generate-then-run every grid point x seed (a cell), each ESTIMATOR on each; write OUT/results.csv,
    aggregate.csv (median and spread over seeds) and OUT/plots. Cells already done in OUT are skipped."""
    if ctx.invoked_subcommand is not None:
        return
    from sim.app.sweep.driver import run_sweep
    from sim.app.sweep.grid import SweepError, load_spec, parse_estimators, parse_seeds, spec_from_cli
    if out_dir is None:
        raise SweepError("--out: required (the sweep's output folder)")
    if spec_file:
        if grid:
            raise SweepError(f"--spec {spec_file}: give the grid in the file or with --grid, not both")
        spec = load_spec(spec_file, scenario)
        spec = type(spec)(spec.scenario, spec.axes, parse_estimators(estimators) or spec.estimators,
                          parse_seeds(seeds) if seeds else spec.seeds, spec.overrides + tuple(overrides))
    else:
        spec = spec_from_cli(scenario or "campus-short", grid, estimators or ("rop",), seeds or "0:1", overrides)
    try:
        summary = run_sweep(spec, out_dir, workers=workers, scheduler=scheduler, keep_datasets=keep_datasets,
                            retry_failed=retry_failed, progress=not (no_progress or as_json), max_cells=max_cells,
                            keep_stale=keep_stale)
    except KeyboardInterrupt:
        click.echo(f"interrupted: finished cells are kept in {out_dir}; run the same command again to resume",
                   err=True)
        sys.exit(130)
    _show(summary, spec, as_json)


def _show(summary, spec, as_json) -> None:
    from sim.app.sweep.driver import mixed_code_warning, stale_summary
    from sim.app.sweep.table import format_aggregate, read_csv
    agg = read_csv(summary.out_dir / "aggregate.csv") if (summary.out_dir / "aggregate.csv").stat().st_size else []
    warning = mixed_code_warning(summary.code_counts, summary.code)
    if as_json:
        echo_json({"out": str(summary.out_dir), "cells": summary.n_cells, "skipped": summary.n_skipped,
                   "run": summary.n_run, "failed": summary.n_failed, "stale": summary.n_stale,
                   "stale_rerun": summary.n_stale_run, "keep_stale": summary.keep_stale, "code": summary.code,
                   "code_counts": summary.code_counts, "warnings": [warning] if warning else [],
                   "wall_s": summary.wall_s, "aggregate": agg})
        return
    click.echo(format_aggregate(agg, spec.axis_keys))
    if warning:
        click.echo(warning, err=True)
    click.echo(f"{summary.n_cells} cells: {summary.n_run} run, {summary.n_skipped} already done, "
               f"{summary.n_failed} failed{stale_summary(summary)}; code {summary.code}; {summary.wall_s:.1f} s; "
               f"tables and plots in {summary.out_dir}")


@sweep.command("report")
@click.argument("out_dir", type=click.Path(exists=True, file_okay=False))
def report(out_dir):
    """Rebuild the tables and plots of the sweep in OUT_DIR from its cell records (no cell is run)."""
    from sim.app.sweep.driver import load_sweep, mixed_code_warning, write_report
    from sim.app.sweep.fingerprint import code_fingerprint
    from sim.app.sweep.table import format_aggregate, read_csv
    spec = load_sweep(out_dir)
    rep = write_report(out_dir, spec)
    agg_csv = next(p for p in rep.tables if p.name == "aggregate.csv")
    click.echo(format_aggregate(read_csv(agg_csv) if agg_csv.stat().st_size else [], spec.axis_keys))
    warning = mixed_code_warning(rep.code_counts, code_fingerprint())
    if warning:
        click.echo(warning, err=True)
    click.echo(f"{rep.n_failed} failed cells; {len(rep.plots)} plots in {out_dir}/plots")
