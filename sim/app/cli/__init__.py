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
    "generate": "sim.app.cli.cmd_generate:generate",
    "export": "sim.app.cli.cmd_export:export",
    "list": "sim.app.cli.cmd_list:list_cmd",
    "bench": "sim.app.cli.cmd_bench:bench",
    "run": "sim.app.cli.cmd_run:run",
    "eval": "sim.app.cli.cmd_eval:eval_cmd",
    "check": "sim.app.cli.cmd_check:check",
    "demo": "sim.app.cli.cmd_demo:demo",
    "predict": "sim.app.cli.cmd_predict:predict",
    "consistency": "sim.app.cli.cmd_consistency:consistency",
    "validate": "sim.app.cli.cmd_validate:validate",
    "sweep": "sim.app.cli.cmd_sweep:sweep",
    "localize": "sim.app.cli.cmd_localize:localize",
    "motion-example": "sim.app.cli.cmd_motion_example:motion_example",
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


def _version_text() -> str:
    """``vo-testbed X (dataset version Y)``: the package, and the version recorded in generated datasets."""
    from importlib.metadata import PackageNotFoundError, version
    from sim.version import __version__ as dataset_version
    try:
        package = version("vo-testbed")
    except PackageNotFoundError:
        package = "unknown (not installed)"
    return f"vo-testbed {package} (dataset version {dataset_version})"


def _print_version(ctx, param, value):
    if value and not ctx.resilient_parsing:
        click.echo(_version_text())
        ctx.exit()


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_print_version,
              help="Print the package and dataset versions and exit.")
def cli():
    """Simulation testbed for stereo visual odometry and visual-inertial navigation."""
    os.environ.setdefault("MUJOCO_GL", "egl")


def main(argv=None):
    """Console entry point. Exit codes (CONVENTIONS.md): 0 success, 1 an accuracy bound exceeded,
    2 bad input (one line: every error of ours derives from :class:`rigs.errors.TestbedError`),
    3 an unexpected internal error (one line; the traceback only with ``--debug``)."""
    from rigs.errors import TestbedError
    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args
    args = [a for a in args if a != "--debug"]
    try:
        cli.main(args=args, prog_name="vo-testbed", standalone_mode=False)
    except click.exceptions.Exit as e:
        sys.exit(e.exit_code)
    except click.UsageError as e:   # bad arguments: one line, as every other bad input (no usage block)
        click.echo(f"Error: {e.format_message()}", err=True)
        sys.exit(e.exit_code)
    except click.ClickException as e:
        e.show()
        sys.exit(e.exit_code)
    except click.exceptions.Abort:
        click.echo("Aborted.", err=True)
        sys.exit(130)
    except TestbedError as e:
        click.echo(f"error: {e}", err=True)
        sys.exit(2)
    except Exception as e:      # noqa: BLE001 - the one place that turns a crash into exit code 3
        if debug:
            import traceback
            traceback.print_exc()
        click.echo(f"internal error: {type(e).__name__}: {e} (run with --debug for the traceback)", err=True)
        sys.exit(3)
