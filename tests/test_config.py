"""Generation config (library level): typed pieces, YAML keys = field names, dotted ``--set`` keys resolved
through the dataclasses, every bad value one line naming the field, the resolved whole round-trips."""
import math

import pytest

from rigs.errors import TestbedError
from rigs.presets import get_rig
from rigs.typed_config import to_mapping
from scenes.base import SceneConfig
from sim.generate_config import GenerateConfig, NoiseConfig, RenderConfig, load_generate_config
from sim.errors import SimError
from sim.motion import MotionConfig
from sim.scenarios import SCENARIOS, get_scenario

# (--set item, text the one-line error must contain: the field, and what is wrong)
BAD_SETS = [
    ("scene.texture=0.2", "scene.texture: unknown key; valid keys: scene.name, scene.seed, scene.texture_richness"),
    ("image_noise=-3", "noise.image_sigma: must be a non-negative number, got -3.0"),
    ("image_noise=nan", "noise.image_sigma: must be a finite number, got 'nan'"),
    ("image_noise=.nan", "noise.image_sigma: must be a finite number, got nan"),
    ("noise.image_sigma=.inf", "noise.image_sigma: must be a finite number, got inf"),
    ("scene.shadows=maybe", "scene.shadows: must be true or false, got 'maybe'"),
    ("scene.shadows=1", "scene.shadows: must be true or false, got 1"),
    ("scene.texture_richness=1.5", "scene.texture_richness: must be in [0, 1], got 1.5"),
    ("scene.lighting=0", "scene.lighting: must be in (0, 4], got 0.0"),
    ("scene.name=atlantis", "scene.name: unknown scene 'atlantis'"),
    ("motion.vibration_pitch_deg=-1", "motion.vibration_pitch_deg: must be a non-negative number, got -1.0"),
    ("motion.path_sample_m=0", "motion.path_sample_m: must be a positive number, got 0.0"),
    ("motion.start_time_ns=1.5", "motion.start_time_ns: must be an integer, got 1.5"),
    ("motion.wobble=1", "motion.wobble: unknown key; valid keys: motion.start_time_ns"),
    ("render.supersample=4", "render.supersample: must be odd, got 4"),
    ("render.supersample=9", "render.supersample: must be in [1, 7], got 9"),
    ("render.supersample=true", "render.supersample: must be an integer, got True"),
    ("seed=-1", "seed: must be a non-negative number, got -1"),
    ("duration_s=0", "duration_s: must be a positive number, got 0.0"),
    ("format=hdf5", "format: unknown 'hdf5'; valid: euroc, kitti, both, rosbag1, rosbag2"),
    ("depth=2", "depth: must be true or false, got 2"),
    ("baseline=-0.2", "baseline: must be a positive finite number, got -0.2"),
    ("imu.rate_hz=abc", "imu.rate_hz: must be a finite number, got 'abc'"),
    ("cam0.fx=.nan", "cam0.fx: must be a finite number, got nan"),
    ("rig=nope", "rig 'nope': unknown preset"),
]


@pytest.mark.parametrize("item, expect", BAD_SETS)
def test_every_bad_set_is_one_line_naming_the_field(item, expect):
    with pytest.raises(TestbedError) as e:
        get_scenario("smoke", [item])
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"--set {item!r}: ") and expect in msg, msg


def test_unknown_key_lists_every_group():
    with pytest.raises(SimError) as e:
        GenerateConfig().with_overrides(["baselin=0.12"])
    msg = str(e.value)
    assert msg.startswith("override 'baselin=0.12': baselin: unknown key; valid keys: ")
    for group in ("scene.<name|seed|texture_richness|lighting|shadows", "motion.<start_time_ns|", "render.<supersample|png_compression|png_strategy|png_filter>",
                  "noise.<image_sigma>", "image_noise", "seed", "duration_s", "baseline", "imu.<", "cam1.<", "wheels.<"):
        assert group in msg, group


def test_sets_resolve_through_the_typed_pieces():
    cfg = GenerateConfig().with_overrides([
        "scene.texture_richness=0.3", "scene.lighting=1", "scene.shadows=true", "motion.vibration_pitch_deg=0.5",
        "motion.vibration_freqs_hz=[1, 2]", "render.supersample=3", "image_noise=2", "seed=5", "duration_s=4",
        "baseline=0.063", "imu=paper002", "imu.rate_hz=400", "cam0.fx=500", "cameras.k1=0.01", "rig.cam1.cx=370",
        "wheels=none"])
    assert cfg.scene == SceneConfig(name="campus", seed=None, texture_richness=0.3, lighting=1.0, shadows=True)
    assert isinstance(cfg.scene.lighting, float) and cfg.scene_config.seed == 5
    assert cfg.motion == MotionConfig(vibration_pitch_deg=0.5, vibration_freqs_hz=(1.0, 2.0))
    assert cfg.render == RenderConfig(supersample=3) and cfg.noise == NoiseConfig(image_sigma=2.0)
    assert cfg.seed == 5 and cfg.duration_s == 4.0
    rig = cfg.rig
    assert rig.baseline == pytest.approx(0.063, abs=1e-15) and rig.imu.name == "paper002" and rig.imu.rate_hz == 400.0
    assert rig.cameras[0].fx == 500.0 and rig.cameras[1].fx == get_rig("cart27").cameras[1].fx
    assert all(c.dist[0] == 0.01 for c in rig.cameras) and rig.cameras[1].cx == 370.0 and rig.wheels is None


def test_set_rig_replaces_the_rig_and_later_keys_apply_to_it():
    cfg = GenerateConfig().with_overrides(["baseline=0.1", "rig=stereo27", "imu.rate_hz=300"])
    assert cfg.rig.name == "stereo27" and cfg.rig.baseline == pytest.approx(0.27) and cfg.rig.imu.rate_hz == 300.0


def test_yaml_file_gets_the_same_checks_as_set(tmp_path):
    f = tmp_path / "g.yaml"
    for text, expect in [("scene: {shadows: maybe}\n", "scene.shadows: must be true or false, got 'maybe'"),
                         ("scene: {texture: 0.2}\n", "scene.texture: unknown key; valid keys: name, seed"),
                         ("noise: {image_sigma: .nan}\n", "noise.image_sigma: must be a finite number, got nan"),
                         ("render: {supersample: 4}\n", "render.supersample: must be odd, got 4"),
                         ("motion: {rest_before_s: -1}\n", "motion.rest_before_s: must be a non-negative number, got -1.0"),
                         ("image_noise: 2\n", "image_noise: unknown key; valid keys: scene, rig, duration_s"),
                         ("rig: {preset: cart27, set: [baseline=-1]}\n", "baseline: must be a positive"),
                         ("rig: {name: x}\n", "rig: cameras: missing field")]:
        f.write_text(text)
        with pytest.raises(TestbedError) as e:
            load_generate_config(f)
        msg = str(e.value)
        assert msg.startswith(f"{f}: ") and expect in msg and "\n" not in msg, msg


def test_load_generate_config_nested_pieces(tmp_path):
    f = tmp_path / "g.yaml"
    f.write_text("scene: {name: indoor, lighting: 0.5}\nrig: {preset: stereo27, set: [baseline=0.12]}\n"
                 "duration_s: 2.5\nmotion: {rest_before_s: 1}\nrender: {supersample: 3}\nnoise: {image_sigma: 0}\n")
    cfg = load_generate_config(f)
    assert cfg == GenerateConfig(scene=SceneConfig(name="indoor", seed=None, lighting=0.5),
                                 rig=get_rig("stereo27", ["baseline=0.12"]), duration_s=2.5,
                                 motion=MotionConfig(rest_before_s=1.0), render=RenderConfig(supersample=3),
                                 noise=NoiseConfig(image_sigma=0.0))
    f.write_text("scene: indoor\nrig: stereo27\n")        # names as shorthand
    assert load_generate_config(f) == GenerateConfig(scene="indoor", rig="stereo27")


@pytest.mark.parametrize("text, needle", [("sceen: x\n", "sceen: unknown key"),
                                          ("duration_s: -3\n", "duration_s"),
                                          ("format: hdf5\n", "format"),
                                          ("scene: [unclosed\n", "YAML syntax error"),
                                          ("- a\n- b\n", "mapping")])
def test_bad_config_files(tmp_path, text, needle):
    f = tmp_path / "g.yaml"
    f.write_text(text)
    with pytest.raises(TestbedError) as e:
        load_generate_config(f)
    msg = str(e.value)
    assert needle in msg and "g.yaml" in msg and "\n" not in msg


def test_resolved_whole_round_trips_through_yaml(tmp_path):
    """to_dict() (what metadata.yaml records as ``config``) reads back to an equal config with the same hash."""
    from rigs.config_io import dump_yaml
    cfg = get_scenario("campus-short", ["baseline=0.2", "scene.lighting=0.7", "motion.vibration_roll_deg=0.1",
                                        "wheels=default", "render.supersample=3", "image_noise=1.5"], seed=3)
    f = tmp_path / "c.yaml"
    f.write_text(dump_yaml(cfg.to_dict()))
    back = load_generate_config(f)
    assert back == cfg and back.config_hash() == cfg.config_hash()


def test_config_hash_changes_with_every_piece():
    base = GenerateConfig(scene="campus", seed=1)
    assert base.config_hash() == GenerateConfig(scene="campus", seed=1).config_hash()
    variants = ["seed=2", "scene.lighting=0.9", "scene.seed=1", "motion.vibration_yaw_deg=0.2", "render.supersample=3",
                "image_noise=2", "baseline=0.2", "imu.rate_hz=400", "duration_s=3"]
    hashes = {base.with_overrides([v]).config_hash() for v in variants}
    assert len(hashes) == len(variants) and base.config_hash() not in hashes


def test_scenarios_are_typed_and_the_scene_seed_follows_the_seed():
    cfg = get_scenario("smoke", seed=4)
    assert cfg == SCENARIOS["smoke"].with_value("seed", 4) and cfg.rig == get_rig("stereo27")
    assert cfg.scene.seed is None and cfg.scene_config.seed == 4 and cfg.duration_s == 3.0
    pinned = cfg.with_overrides(["scene.seed=7"])
    assert pinned.scene_config.seed == 7 and pinned.seed == 4
    assert get_scenario("campus-short", ["image_noise=0"]).noise.image_sigma == 0.0


def test_pieces_validate_on_construction():
    with pytest.raises(TestbedError, match=r"^scene.texture_richness: must be in \[0, 1\], got 1.5$"):
        SceneConfig(texture_richness=1.5)
    with pytest.raises(TestbedError, match="^scene.shadows: must be true or false, got 'yes'$"):
        SceneConfig(shadows="yes")
    with pytest.raises(SimError, match="^motion.vibration_heave_m: must be a finite number, got nan$"):
        MotionConfig(vibration_heave_m=math.nan)
    with pytest.raises(SimError, match="^noise.image_sigma: must be a non-negative number, got -1.0$"):
        NoiseConfig(image_sigma=-1)
    d = to_mapping(SceneConfig())
    assert {k: d[k] for k in ("name", "seed", "texture_richness", "lighting", "shadows")} == \
        {"name": "campus", "seed": 0, "texture_richness": 0.8, "lighting": 1.0, "shadows": None}
