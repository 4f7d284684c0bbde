"""``vo-testbed motion-example``: write an example trajectory to replay with ``generate --motion FILE``."""
from __future__ import annotations

import click


@click.command("motion-example")
@click.argument("kind", type=click.Choice(["helix", "walk"]))
@click.argument("out", type=click.Path(dir_okay=False))
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the walk's stream 'motion'.")
@click.option("--rate", type=click.FloatRange(min=1.0, max=10000.0), default=100.0, show_default=True,
              help="Pose rate (Hz).")
@click.option("--duration", type=click.FloatRange(min=0.5, max=3600.0), default=10.0, show_default=True,
              help="Length (s).")
def motion_example(kind, out, seed, rate, duration):
    """Write a TUM file of body poses inside the indoor scene: a helix, or a seeded hand-held-like walk."""
    from rigs.trajfile import write_tum
    from sim.replay_paths import hand_walk, helix
    traj = helix(duration, rate) if kind == "helix" else hand_walk(seed, duration, rate)
    write_tum(out, traj)
    click.echo(f"wrote {len(traj)} {kind} poses ({duration:g} s at {rate:g} Hz) to {out}")
