"""Shared click options and output helpers for the subcommands."""
from __future__ import annotations

import json

import click

json_option = click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON instead of a table.")
set_option = click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
                          help="Set any configuration field by its dotted name (value parsed as YAML, type- and "
                               "range-checked; applied in order, after the other flags): scene.texture_richness=0.3, "
                               "scene.lighting=0.7, scene.shadows=true, motion.vibration_pitch_deg=0.5, "
                               "render.supersample=3, image_noise=2 (= noise.image_sigma), seed=3, rig=stereo27; "
                               "rig keys: baseline=0.063, imu=paper002, imu.rate_hz=400, cam0.fx=500, "
                               "cameras.k1=0.01, wheels=none. A wrong key lists the valid ones.")


def echo_json(obj) -> None:
    click.echo(json.dumps(obj, indent=2, sort_keys=True, default=_default))


def _default(o):
    import numpy as np
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if hasattr(o, "to_dict"):
        return o.to_dict()
    return str(o)


opt_option = click.option("--opt", "estimator_opts", multiple=True, metavar="KEY=VALUE",
                          help="Estimator option, e.g. --opt min_matches=40 --opt cov=chain_bootstrap (values parsed "
                               "as YAML); an experimental one as --opt experimental.KEY=VALUE.")


def parse_opts(items, frontend=None) -> dict:
    """``("cov=chain_bootstrap", "min_matches=40")`` -> ``{"cov": "chain_bootstrap", "min_matches": 40}``."""
    from rigs.typed_config import parse_value
    out = {} if frontend is None else {"frontend": frontend}
    for item in items:
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise click.BadParameter(f"expected KEY=VALUE, got {item!r}", param_hint="--opt")
        out[key] = parse_value(raw, f"--opt {key}", lambda m: click.BadParameter(m, param_hint="--opt"))
    return out
