"""``vo-testbed consistency``: NEES and drift-spread of an estimator over Monte-Carlo runs."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts, set_option


@click.command("consistency")
@click.option("--scenario", default="campus-short", show_default=True)
@click.option("--estimator", default="rop", show_default=True,
              help="Registered name or 'package.module:Class'; rop's covariance: --opt cov=propagated|chain_bootstrap.")
@click.option("--runs", type=int, default=30, show_default=True)
@click.option("--image-noise", type=float, default=1.0, show_default=True, help="Image noise sigma, grey levels.")
@click.option("--max-frames", type=int, default=None)
@click.option("--frontend", type=click.Choice(["klt", "orb", "sift"]), default=None)
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False))
@click.option("--vary", type=click.Choice(["noise", "scene"]), default="noise", show_default=True,
              help="noise: render once, re-noise per run; scene: also re-render each run from a new scenario seed.")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
              help="Runs in parallel processes (same results).")
@click.option("--oracle-tracks", "oracle_px", type=click.FloatRange(min=0), default=None, metavar="PX",
              help="rop only: exact track positions (rendered depth + truth) plus PX iid pixel noise, to check "
                   "the back-end's error propagation on its own noise model.")
@click.option("--renoise", type=click.IntRange(min=0), default=0, show_default=True, metavar="R",
              help="Score the covariance of R re-noised replicates of each run (any estimator; (1+R)x the time) "
                   "instead of the estimator's own: vo.errorprop.renoise.")
@click.option("--no-progress", is_flag=True)
@set_option
@opt_option
@json_option
def consistency(scenario, estimator, runs, image_noise, max_frames, frontend, out_dir, vary, workers, oracle_px,
                renoise, no_progress, overrides, estimator_opts, as_json):
    """Render SCENARIO once, re-noise it RUNS times, run ESTIMATOR, report NEES and predicted vs measured drift."""
    from sim.app.nees import consistency as run_mc, write_outputs
    res = run_mc(scenario, estimator, runs, image_noise, options=parse_opts(estimator_opts, frontend) or None,
                 progress=not (no_progress or as_json), max_frames=max_frames, workers=workers, vary=vary,
                 oracle_px=oracle_px, overrides=overrides, renoise=renoise)
    paths = write_outputs(res, out_dir)
    echo_json(res.to_dict()) if as_json else click.echo(res.text() + f"\nplot: {paths['plot']}")
