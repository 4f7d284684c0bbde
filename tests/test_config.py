"""Generation config: YAML keys are the field names; bad files fail in one line naming file and field."""
import pytest

from sim.config import GenerateConfig, load_generate_config
from sim.errors import SimError


def test_load_generate_config(tmp_path):
    f = tmp_path / "g.yaml"
    f.write_text("scene: indoor\nrig: stereo27\nduration_s: 2.5\noverrides: [baseline=0.12, scene.lighting=0.5]\n")
    cfg = load_generate_config(f)
    assert cfg == GenerateConfig(scene="indoor", rig="stereo27", duration_s=2.5,
                                 overrides=("baseline=0.12", "scene.lighting=0.5"))
    parts = cfg.split_overrides()
    assert parts["rig"] == ["baseline=0.12"] and parts["scene"] == {"lighting": 0.5}


@pytest.mark.parametrize("text, needle", [("sceen: x\n", "unknown field 'sceen'"),
                                          ("duration_s: -3\n", "duration_s"),
                                          ("format: hdf5\n", "format"),
                                          ("scene: [unclosed\n", "g.yaml"),
                                          ("- a\n- b\n", "mapping")])
def test_bad_config_files(tmp_path, text, needle):
    f = tmp_path / "g.yaml"
    f.write_text(text)
    with pytest.raises(SimError) as e:
        load_generate_config(f)
    msg = str(e.value)
    assert needle in msg and "g.yaml" in msg and "\n" not in msg


def test_config_hash_changes_with_content():
    a = GenerateConfig(scene="campus", seed=1)
    assert a.config_hash() == GenerateConfig(scene="campus", seed=1).config_hash()
    assert a.config_hash() != GenerateConfig(scene="campus", seed=2).config_hash()
