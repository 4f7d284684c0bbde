"""Experimental estimator options (vo.estimators.experimental): given only as ``experimental.<field>``, flat or
nested; the bare name and an unknown experimental key are one-line errors; the product defaults and the VINS
presets are untouched."""
import dataclasses

import pytest

from vo.errors import EstimatorError
from vo.rop.rop_config import EXPERIMENTAL as ROP_EXPERIMENTAL, RopConfig
from vo.vins.vins_config import EXPERIMENTAL as VINS_EXPERIMENTAL, PRESETS, VinsConfig

# one non-default value per experimental field
ROP_VALUES = {"weights": "sampson", "klt_refine": "affine", "rop_loss": "tukey", "moving_prior": "velocity"}
VINS_VALUES = {"n_count": "window", "weight_min": 0.1, "weight_max": 1.0, "landmark": "inverse-depth",
               "shift_depth": True, "hold_gauge": True, "init_min_excitation": 0.25,
               "init_provisional_scale_std": 0.15, "init_confirm_s": 5.0}


def _build(kind, options):
    return RopConfig.from_options(options) if kind == "rop" else VinsConfig.from_options("base", options)


@pytest.mark.parametrize("kind, values, fields", [("rop", ROP_VALUES, ROP_EXPERIMENTAL),
                                                  ("vins", VINS_VALUES, VINS_EXPERIMENTAL)])
def test_each_experimental_field_needs_the_prefix(kind, values, fields):
    assert set(values) == set(fields)
    default = _build(kind, {})
    for field, value in values.items():
        assert getattr(default, field) != value                 # a non-default alternative
        flat = _build(kind, {f"experimental.{field}": value})
        nested = _build(kind, {"experimental": {field: value}})
        assert getattr(flat, field) == value and flat == nested
        assert dataclasses.replace(flat, **{field: getattr(default, field)}) == default   # nothing else moves
        with pytest.raises(EstimatorError, match=rf"^{kind}\.{field}: an experimental option .* give it as "
                                                 rf"experimental\.{field}$") as e:
            _build(kind, {field: value})
        assert "\n" not in str(e.value)


@pytest.mark.parametrize("kind", ["rop", "vins"])
def test_unknown_experimental_keys_and_bad_shapes_are_refused(kind):
    with pytest.raises(EstimatorError, match=rf"^{kind}\.experimental\.min_matches: not an experimental option"):
        _build(kind, {"experimental.min_matches": 40})
    with pytest.raises(EstimatorError, match=rf"^{kind}\.experimental: expected a mapping"):
        _build(kind, {"experimental": "weights=sampson"})


def test_removed_rop_options_are_unknown_keys():
    for key in ("ransac_method", "constant_velocity"):
        with pytest.raises(EstimatorError, match=rf"rop\.{key}: unknown key"):
            RopConfig.from_options({key: True})


def test_vins_presets_take_no_experimental_field():
    """The registered configurations (vins-ac-me, ...) stay product configurations: their fixed options are
    not experimental ones, and each gives the same config as its options on the base preset."""
    for name, fixed in PRESETS.items():
        assert not set(fixed) & VINS_EXPERIMENTAL
        assert VinsConfig.from_options(name, {}) == VinsConfig.from_options("base", fixed)
