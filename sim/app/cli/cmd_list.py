"""``vo-testbed list``: scenes, rigs, IMU models, scenarios and estimators, with their details."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option


@click.command("list")
@click.option("--names", "names_only", is_flag=True, help="Only the names (no scene or scenario is resolved).")
@json_option
def list_cmd(names_only, as_json):
    """List the built-in scenes (route length, GCPs, knobs), rigs (resolution, baseline, rates), IMU models,
    scenarios (scene, rig, duration, frames) and estimators, and how to plug in your own."""
    from sim.app.catalogue import catalogue, catalogue_text
    cat = catalogue(details=not names_only)
    if as_json:
        echo_json(cat)
    elif names_only:
        for key, names in cat.items():
            if key != "plugins":
                click.echo(f"{key.replace('_', ' ')}: {', '.join(names)}")
    else:
        click.echo(catalogue_text(cat))
