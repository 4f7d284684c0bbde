"""``vo-testbed predict``: error-propagation predictions (seed 001 section 3)."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option, opt_option, parse_opts, set_option


@click.group("predict")
def predict():
    """Error-propagation predictions: stereo range error, cross-site localisation accuracy, image-noise spread."""


def _as_flag(flag: str, fn, *args):
    """Call a library function whose VoError names its parameter; report it as ``flag`` (exit 2)."""
    from vo.errors import VoError
    try:
        return fn(*args)
    except VoError as e:
        raise click.BadParameter(str(e).split(": ", 1)[-1], param_hint=f"'{flag}'") from None


@predict.command("range")
@click.option("--rig", "rig_name", default="stereo27", show_default=True)
@click.option("--ranges", default="1:30", show_default=True, help="'5,10,20' or 'start:stop[:step]' metres.")
@click.option("--sigma-p", type=click.FloatRange(min=0, min_open=True), default=1 / 3, show_default=True,
              help="Parallax (disparity) error, px (> 0).")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None, help="Write a PNG plot.")
@set_option
@json_option
def range_cmd(rig_name, ranges, sigma_p, plot_path, overrides, as_json):
    """Range error against range for a rig (eq. 7 and the general triangulation covariance)."""
    from rigs.overrides import apply_overrides
    from rigs.presets import get_rig
    from vo.errorprop.predict import parse_ranges, plot_range_prediction, predict_range
    rig = apply_overrides(get_rig(rig_name), list(overrides))
    pred = _as_flag("--sigma-p", predict_range, rig, _as_flag("--ranges", parse_ranges, ranges), sigma_p)
    if plot_path:
        plot_range_prediction(pred, plot_path)
    echo_json(pred.to_dict()) if as_json else click.echo(pred.table())


@predict.command("cross-site")
@click.option("--preset", type=click.Choice(["paper-ff", "paper-fb"]), default=None)
@click.option("--landmarks", "landmarks_file", type=click.Path(dir_okay=False), default=None,
              help="YAML with CrossSiteConfig fields (f_px, baseline_m, sigma_p_px, sigma_theta_px, "
                   "previous_site, current_site, landmarks).")
@click.option("--monte-carlo", "mc", type=click.IntRange(min=0), default=0,
              help="Also run N Monte-Carlo draws of the same model.")
@click.option("--seed", type=int, default=0)
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None)
@json_option
def cross_site_cmd(preset, landmarks_file, mc, seed, plot_path, as_json):
    """Cross-site localisation accuracy in percent of distance travelled (eq. 9-13)."""
    import numpy as np
    from vo.errorprop.crosssite import (CROSS_SITE_PRESETS, cross_site_accuracy, cross_site_monte_carlo,
                                        load_cross_site_config)
    from vo.errorprop.predict import plot_cross_site
    if bool(preset) == bool(landmarks_file):
        raise click.UsageError("give exactly one of --preset or --landmarks")
    cfg = CROSS_SITE_PRESETS[preset] if preset else load_cross_site_config(landmarks_file)
    res = cross_site_accuracy(cfg)
    out = {"config": preset or landmarks_file, "analytic": res.to_dict()}
    if mc:
        out["monte_carlo"] = cross_site_monte_carlo(cfg, mc, np.random.default_rng(seed)).to_dict()
    if plot_path:
        plot_cross_site(cfg, res, plot_path)
    if as_json:
        echo_json(out)
        return
    click.echo(f"{out['config']}: new-site sigma {res.sigma_pos_m:.4f} m over {res.distance_m:.2f} m "
               f"= {res.accuracy_percent:.3f}% of distance travelled")
    if mc:
        click.echo(f"Monte Carlo ({mc} draws): {out['monte_carlo']['accuracy_percent']:.3f}%")


@predict.command("renoise")
@click.option("--dataset", "dataset_dir", required=True, type=click.Path(exists=True, file_okay=False),
              help="Dataset folder (ours EuRoC/KITTI, real EuRoC mav0 parent, KITTI sequences/NN).")
@click.option("--estimator", default="rop", show_default=True, help="Registered name or 'package.module:Class'.")
@click.option("--replicates", type=click.IntRange(min=3), default=10, show_default=True)
@click.option("--sigma", type=click.FloatRange(min=0), default=None,
              help="Image noise, grey levels (default: estimated from the first left image).")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--max-frames", type=click.IntRange(min=1), default=None)
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None, help="Write a PNG plot.")
@opt_option
@json_option
def renoise_cmd(dataset_dir, estimator, replicates, sigma, seed, max_frames, plot_path, estimator_opts, as_json):
    """Pose spread from image noise: re-run ESTIMATOR on DATASET re-noised at its own noise level."""
    from vo.dataset import open_dataset
    from vo.errorprop.renoise import renoise_covariance
    res = renoise_covariance(open_dataset(dataset_dir), estimator, parse_opts(estimator_opts, None) or None,
                             replicates, sigma, seed, max_frames=max_frames)
    if plot_path:
        res.plot(plot_path)
    echo_json(res.to_dict()) if as_json else click.echo(res.text())
