"""``--opt KEY=VALUE`` values parse as YAML 1.2 numbers (``1e-8`` is a float, as in every config file),
and a malformed value is one usage error naming the option."""
import click
import pytest

from sim.app.cli.cmd_localize import crosssite_config
from sim.app.cli.options import parse_opts


def test_scientific_notation_without_a_dot_is_a_float():
    o = parse_opts(["gyr_w=1e-8", "acc_n=2E-3", "window_size=20", "robust=huber", "init=truth", "flag=true"])
    assert o == {"gyr_w": 1e-8, "acc_n": 2e-3, "window_size": 20, "robust": "huber", "init": "truth",
                 "flag": True}
    assert isinstance(o["gyr_w"], float) and isinstance(o["window_size"], int)


def test_malformed_value_is_a_usage_error_naming_the_option():
    with pytest.raises(click.BadParameter, match=r"--opt klt_config: YAML syntax error"):
        parse_opts(["klt_config={win: 11"])
    with pytest.raises(click.BadParameter, match="expected KEY=VALUE"):
        parse_opts(["win"])


def test_localize_set_values_parse_the_same_way():
    cfg = crosssite_config("ff", ["prior_rot_sigma_rad=5e-2"])
    assert cfg.prior_rot_sigma_rad == 0.05
