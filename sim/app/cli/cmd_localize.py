"""``vo-testbed localize``: localize a stop-and-go traverse site by site (seed 001 cross-site BA).

Only parses arguments and calls :func:`vo.crosssite.traverse_eval.run_and_write`; never imports mujoco.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import click


def crosssite_config(mode: str, items) -> object:
    """CrossSiteConfig from ``--mode`` and ``--set field=value`` items (values parsed as YAML)."""
    import dataclasses
    from rigs.typed_config import parse_value
    from vo.crosssite import CrossSiteConfig
    from vo.errors import VoError
    names = {f.name for f in dataclasses.fields(CrossSiteConfig)}
    kw = {"mode": mode}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or key not in names:
            raise VoError(f"--set {item!r}: expected FIELD=VALUE with FIELD one of the crosssite config fields "
                          f"(e.g. asift_max_tilt, sift_features)")
        kw[key] = parse_value(value, f"--set {key}", VoError)
    return CrossSiteConfig(**kw)


def _strict(obj):
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_strict(v) for v in obj]
    return obj


@click.command("localize")
@click.option("--dataset", "dataset", required=True, type=click.Path(), help="Traverse dataset folder "
              "(`vo-testbed generate --scenario yutu-traverse`).")
@click.option("--method", type=click.Choice(["crosssite"]), default="crosssite", show_default=True,
              help="crosssite: seed 001 site-to-site bundle adjustment.")
@click.option("--mode", type=click.Choice(["ff", "fb"]), default="ff", show_default=True,
              help="Matching regions: ff forward-forward (back-projection), fb forward-backward (ground overlap).")
@click.option("--out", "out", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option("--max-sites", type=click.IntRange(min=0), default=0, show_default=True,
              help="Only the first N sites (0: all).")
@click.option("--set", "items", multiple=True, metavar="FIELD=VALUE", help="A CrossSiteConfig field (repeatable).")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON instead of the table.")
def localize(dataset, method, mode, out, max_sites, items, as_json):
    """Localize each site against the previous one (site 0 known); print a per-site table; write
    site_poses_tum.txt, summary.json, traverse_map.png and matching.png to --out."""
    from vo.crosssite.traverse_eval import format_table, run_and_write
    from vo.errors import DatasetError
    if not Path(dataset).is_dir():
        raise DatasetError(f"--dataset {dataset}: no such folder")
    cfg = crosssite_config(mode, items)
    s = run_and_write(dataset, out, cfg, max_sites, progress=not as_json)
    if as_json:
        click.echo(json.dumps(_strict(json.loads(json.dumps(s, default=float))), indent=1))
        return
    from vo.crosssite.model_check import format_model_rows
    click.echo(format_table(s["sites"]))
    if s["model_vs_ba"]:
        click.echo("seed 001 eq. 9-13 model vs BA, per site pair (one sample each, not a Monte Carlo):")
        click.echo(format_model_rows(s["model_vs_ba"]))
    click.echo(f"mean per-leg error: DR {s['dr_mean_leg_err_pct']:.2f} %, BA {s['ba_mean_leg_err_pct']:.2f} % of the leg")
    click.echo(f"mean per-site error: DR {s['dr_mean_err_pct']:.2f} %, BA {s['ba_mean_err_pct']:.2f} % of distance; "
               f"final: DR {s['dr_final_err_pct']:.2f} %, BA {s['ba_final_err_pct']:.2f} % over {s['distance_m']:.1f} m; "
               f"{s['n_ok']}/{s['n_sites'] - 1} sites ok; DR NEES (3 dof) mean {s['dr_mean_nees_3dof']:.2f}")
    click.echo(f"wrote {', '.join(s['files'].values())} and {Path(out) / 'summary.json'}")
