"""``vo-testbed check``: CI accuracy gate for any VO (ours by name, a Python class, or a command)."""
from __future__ import annotations

import math
import sys

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts, set_option


def _bound(ctx, param, value):
    if value is not None and not value >= 0:          # negative or NaN
        raise click.BadParameter(f"must be a finite number >= 0, got {value}")
    if value is not None and math.isinf(value):
        raise click.BadParameter(f"{value} is a bound that can never fail; give a finite number >= 0")
    return value


def _coverage(ctx, param, value):
    if not (0 < value <= 1) or math.isnan(value):
        raise click.BadParameter(f"must be in (0, 1], got {value}")
    return value


@click.command("check")
@click.option("--estimator", required=True,
              help="A built-in name (see `vo-testbed list`), a Python class 'package.module:Class' implementing "
                   "vo.estimators.base.Estimator, or 'cmd:<command with {dataset} and {out}>': the program gets "
                   "a read-only folder with the sensor data only (images, IMU, calibration) as {dataset} and "
                   "writes a TUM trajectory of the left camera to {out}.")
@click.option("--scenario", default="campus-short", show_default=True)
@click.option("--max-drift", type=float, default=None, callback=_bound, help="Bound on the drift ratio, percent.")
@click.option("--max-ate", type=float, default=None, callback=_bound,
              help="Bound on ATE RMSE after first-pose anchoring, m.")
@click.option("--max-rpe", type=float, default=None, callback=_bound,
              help="Bound on per-frame RPE translation RMSE, m.")
@click.option("--min-coverage", type=float, default=0.95, show_default=True, callback=_coverage,
              help="Fail when fewer than this fraction of the frames have an estimated pose.")
@click.option("--frontend", type=click.Choice(["klt", "orb", "sift"]), default=None)
@click.option("--seed", type=int, default=None, help="Override the scenario's seed.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None, help="Keep trajectory and metrics.")
@click.option("--timeout", "timeout_s", type=float, default=None,
              help="Seconds a cmd: program may run before its process group is ended (exit 2); default 20 x the "
                   "sequence's duration + 60 s.")
@click.option("--isolation", type=click.Choice(["auto", "required", "view-only"]), default="auto", show_default=True,
              help="How a cmd: program is isolated: 'auto' uses namespaces (bwrap or unshare) where they work and "
                   "says which it used; 'required' refuses to run without them; 'view-only' only the sensor view.")
@click.option("--verbose", "-v", is_flag=True, help="Also show what an external program printed on stderr.")
@click.option("--no-progress", is_flag=True)
@opt_option
@set_option
@json_option
def check(estimator, scenario, max_drift, max_ate, max_rpe, min_coverage, frontend, seed, out_dir, timeout_s,
          isolation, verbose, no_progress, estimator_opts, overrides, as_json):
    """Generate (or reuse, cached by configuration hash) SCENARIO, run ESTIMATOR, print the metrics.

    Only poses the estimator produced count: frames by status ok (measured) and coasting (predicted
    without a measurement) are covered and scored; init and lost (placeholders) are not.

    Exit codes: 0 every bound met, 1 a bound exceeded, coverage below --min-coverage or an estimator that
    never initialised, 2 bad input (no bound, a negative, infinite or NaN bound, an unknown estimator, an
    oracle, a program that failed, timed out or changed its input, --isolation required where no namespace
    works), 3 internal error."""
    from sim.app.check import check as run_check
    from vo.estimators.registry import ExternalCommandError
    if max_drift is None and max_ate is None and max_rpe is None:
        raise click.UsageError("give at least one bound: --max-drift, --max-ate or --max-rpe")
    try:
        res = run_check(estimator, scenario, {"max_drift": max_drift, "max_ate": max_ate, "max_rpe": max_rpe},
                        overrides=overrides, seed=seed, out_dir=out_dir, options=parse_opts(estimator_opts, frontend),
                        progress=not (no_progress or as_json), min_coverage=min_coverage, timeout_s=timeout_s,
                        isolation=isolation)
    except ExternalCommandError as e:
        if e.stderr.strip():
            click.echo("program stderr:\n" + e.stderr.rstrip(), err=True)
        raise
    echo_json(res.to_dict()) if as_json else click.echo(res.text(verbose=verbose))
    if not res.passed:
        sys.exit(1)
