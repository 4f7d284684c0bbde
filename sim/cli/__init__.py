"""``vo-testbed`` command line: parses arguments and calls library functions.

Each subcommand lives in its own module and is imported only when invoked, so
``vo-testbed eval`` never imports mujoco.
"""
from __future__ import annotations

import importlib
import os
import sys

import click

# name -> "module:attribute" of a click command
COMMANDS = {
    "generate": "sim.cli.cmd_generate:generate",
    "list": "sim.cli.cmd_list:list_cmd",
    "bench": "sim.cli.cmd_bench:bench",
    "run": "sim.cli.cmd_run:run",
    "eval": "sim.cli.cmd_eval:eval_cmd",
    "check": "sim.cli.cmd_check:check",
    "demo": "sim.cli.cmd_demo:demo",
    "predict": "sim.cli.cmd_predict:predict",
    "consistency": "sim.cli.cmd_consistency:consistency",
    "validate": "sim.cli.cmd_validate:validate",
}


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(name for name, target in COMMANDS.items() if _available(target))

    def get_command(self, ctx, name):
        target = COMMANDS.get(name)
        if target is None or not _available(target):
            return None
        module, attr = target.split(":")
        return getattr(importlib.import_module(module), attr)


def _available(target: str) -> bool:
    module = target.split(":")[0]
    return importlib.util.find_spec(module) is not None


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
def cli():
    """Simulation testbed for stereo visual odometry and visual-inertial navigation."""
    os.environ.setdefault("MUJOCO_GL", "egl")


def main():
    """Console entry point: library errors become a one-line message and exit code 2."""
    from rigs.errors import RigError
    from vo.errors import VoError
    errors = (RigError, VoError)
    try:
        from sim.errors import SimError
        errors = errors + (SimError,)
    except ImportError:
        pass
    try:
        from scenes.errors import SceneError
        errors = errors + (SceneError,)
    except ImportError:
        pass
    try:
        cli.main(standalone_mode=False)
    except click.exceptions.Exit as e:
        sys.exit(e.exit_code)
    except click.ClickException as e:
        e.show()
        sys.exit(e.exit_code)
    except click.exceptions.Abort:
        click.echo("Aborted.", err=True)
        sys.exit(130)
    except errors as e:
        click.echo(f"error: {e}", err=True)
        sys.exit(2)
