"""``vo-testbed check``: CI accuracy gate for any VO (ours by name, a Python class, or a command)."""
from __future__ import annotations

import sys

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts, set_option


@click.command("check")
@click.option("--estimator", required=True,
              help="A built-in name (rop, klt-pnp, orb-pnp), a Python class 'package.module:Class' implementing "
                   "vo.estimators.base.Estimator, or 'cmd:<command with {dataset} and {out}>' that reads the "
                   "dataset folder and writes a TUM trajectory of the left camera to {out}.")
@click.option("--scenario", default="campus-short", show_default=True)
@click.option("--max-drift", type=float, default=None, help="Bound on the drift ratio, percent.")
@click.option("--max-ate", type=float, default=None, help="Bound on ATE RMSE after first-pose anchoring, m.")
@click.option("--max-rpe", type=float, default=None, help="Bound on per-frame RPE translation RMSE, m.")
@click.option("--frontend", type=click.Choice(["klt", "orb", "sift"]), default=None)
@click.option("--seed", type=int, default=None, help="Override the scenario's seed.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None, help="Keep trajectory and metrics.")
@click.option("--no-progress", is_flag=True)
@opt_option
@set_option
@json_option
def check(estimator, scenario, max_drift, max_ate, max_rpe, frontend, seed, out_dir, no_progress, estimator_opts,
          overrides, as_json):
    """Generate (or reuse, cached by configuration hash) SCENARIO, run ESTIMATOR, print the metrics and
    exit 1 when any given bound is exceeded (2 on a usage or input error)."""
    from sim.app.check import check as run_check
    options = parse_opts(estimator_opts, frontend)
    res = run_check(estimator, scenario, {"max_drift": max_drift, "max_ate": max_ate, "max_rpe": max_rpe},
                    overrides=overrides, seed=seed, out_dir=out_dir, options=options,
                    progress=not (no_progress or as_json))
    echo_json(res.to_dict()) if as_json else click.echo(res.text())
    if not res.passed:
        sys.exit(1)
