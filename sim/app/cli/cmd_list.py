"""``vo-testbed list``: scenes, rigs, IMU models, scenarios, estimators."""
from __future__ import annotations

import click

from sim.app.cli.options import echo_json, json_option


def catalogue() -> dict:
    from rigs.imu_models import imu_model_names
    from rigs.presets import rig_names
    from scenes.registry import scene_names
    from sim.scenarios import scenario_names
    from vo.estimators.registry import estimator_names
    return {"scenes": list(scene_names()), "rigs": list(rig_names()), "imu_models": list(imu_model_names()),
            "scenarios": scenario_names(), "estimators": list(estimator_names())}


@click.command("list")
@json_option
def list_cmd(as_json):
    """List the built-in scenes, rigs, IMU models, scenarios and estimators."""
    cat = catalogue()
    if as_json:
        echo_json(cat)
        return
    for key, names in cat.items():
        click.echo(f"{key.replace('_', ' ')}: {', '.join(names)}")
