"""One ``--set`` grammar: a typed config's dotted keys (``rigs.typed_config.replace_path``) reach the rig's own
keys (``rigs.overrides``) through the field's ``KeyGrammar``, so ``rig.<key>``, the bare rig key and the rig's
override list give the same rig, and keys the rig's dataclass fields do not spell (``cam0.fx``, ``baseline``)
work inside a config too."""
import numpy as np
import pytest

from rigs.errors import RigError
from rigs.overrides import apply_overrides
from rigs.typed_config import has_path, replace_path, valid_keys
from sim.generate_config import GenerateConfig
from sim.errors import SimError


@pytest.mark.parametrize("key, value", [("baseline", 0.4), ("cam0.fx", 500.0), ("cameras.k1", -0.1),
                                        ("imu.rate_hz", 400.0), ("camera_rate_hz", 15.0)])
def test_rig_keys_are_one_grammar(key, value):
    cfg = GenerateConfig()
    expect = apply_overrides(cfg.rig, [f"{key}={value}"])
    assert expect != cfg.rig
    assert replace_path(cfg, f"rig.{key}", value, SimError).rig == expect
    assert cfg.with_value(f"rig.{key}", value).rig == expect
    assert cfg.with_value(key, value).rig == expect
    assert cfg.with_overrides([f"{key}={value}"]).rig == expect


def test_baseline_through_the_config_moves_camera_1():
    rig = GenerateConfig().with_value("rig.baseline", 0.4).rig
    assert np.linalg.norm(rig.T_c0_c1[:3, 3]) == pytest.approx(0.4, abs=1e-12)


def test_rig_keys_are_checked_by_the_rig_grammar():
    cfg = GenerateConfig()
    assert has_path(GenerateConfig, "rig.cam0.fx") and "rig" in valid_keys(GenerateConfig)
    with pytest.raises(RigError, match=r"^cam7\.fx: unknown key; valid keys: baseline, imu, wheels"):
        replace_path(cfg, "rig.cam7.fx", 1.0, SimError)
    with pytest.raises(RigError, match="baseline: must be a positive finite number, got -1"):
        cfg.with_value("baseline", -1)
    with pytest.raises(SimError, match=r"^baselin: unknown key; valid keys: .*rig, baseline, imu, wheels"):
        cfg.with_value("baselin", 1)
