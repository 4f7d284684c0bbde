"""``vo-testbed generate`` configuration at the command line: every bad ``--set``/``--config`` exits 2 with one
line naming the field and writes nothing; ``--config FILE`` plus flags: flags win, and ``metadata.yaml``
records the resolved whole, from which the same dataset is generated again."""
import hashlib

import pytest
import yaml

from sim.app.cli import main
from sim.generate_config import load_generate_config


def run(capsys, *argv) -> tuple:
    try:
        main(list(argv))
        code = 0
    except SystemExit as e:
        code = e.code
    cap = capsys.readouterr()
    return code, [ln for ln in cap.err.splitlines() if ln.strip()]


def digest(path) -> dict:
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*")) if p.is_file()}


BAD = [
    (["--set", "scene.texture=0.2"], "scene.texture: unknown key; valid keys: scene.name, scene.seed, "
                                     "scene.texture_richness, scene.lighting, scene.shadows"),
    (["--set", "image_noise=-3"], "noise.image_sigma: must be a non-negative number, got -3.0"),
    (["--set", "image_noise=nan"], "noise.image_sigma: must be a finite number, got 'nan'"),
    (["--set", "scene.shadows=maybe"], "scene.shadows: must be true or false, got 'maybe'"),
    (["--set", "baselin=0.12"], "baselin: unknown key; valid keys: scene.<name|seed|texture_richness|lighting|shadows"),
    (["--set", "render.supersample=2"], "render.supersample: must be odd, got 2"),
    (["--set", "motion.vibration_roll_deg=-.inf"], "motion.vibration_roll_deg: must be a finite number, got -inf"),
    (["--set", "nonsense"], "--set 'nonsense': expected key=value"),
    (["--duration", "-1"], "--duration: duration_s: must be a positive number, got -1.0"),
    (["--scene", "atlantis"], "--scene: scene.name: unknown scene 'atlantis'; valid: "),
    (["--rig", "nope"], "--rig: rig 'nope': unknown preset"),
]


@pytest.mark.parametrize("args, expect", BAD)
def test_bad_set_or_flag_exits_2_with_one_line(tmp_path, capsys, args, expect):
    out = tmp_path / "ds"
    code, err = run(capsys, "generate", "--no-images", "--no-progress", "--out", str(out), *args)
    assert code == 2 and len(err) == 1 and err[0].startswith("error: ") and expect in err[0], err
    assert not out.exists()


def test_unknown_key_error_lists_scene_motion_render_and_image_noise(tmp_path, capsys):
    code, err = run(capsys, "generate", "--no-images", "--out", str(tmp_path / "ds"), "--set", "baselin=0.12")
    assert code == 2 and len(err) == 1
    for group in ("scene.<", "motion.<", "render.<supersample|png_compression", "noise.<image_sigma>", "image_noise", "baseline"):
        assert group in err[0], group


@pytest.mark.parametrize("text, expect", [
    ("scene: {texture: 0.2}\n", "scene.texture: unknown key; valid keys: name, seed, texture_richness"),
    ("noise: {image_sigma: .nan}\n", "noise.image_sigma: must be a finite number, got nan"),
    ("scene: {name: campus, shadows: maybe}\n", "scene.shadows: must be true or false, got 'maybe'"),
    ("duraton_s: 3\n", "duraton_s: unknown key; valid keys: scene, rig, duration_s"),
    ("render: {supersample: 3.5}\n", "render.supersample: must be an integer, got 3.5"),
])
def test_bad_config_file_exits_2_with_one_line(tmp_path, capsys, text, expect):
    f = tmp_path / "g.yaml"
    f.write_text(text)
    out = tmp_path / "ds"
    code, err = run(capsys, "generate", "--no-images", "--config", str(f), "--out", str(out))
    assert code == 2 and len(err) == 1 and err[0].startswith(f"error: {f}: ") and expect in err[0], err
    assert not out.exists()


def test_config_and_scenario_together_is_a_usage_error(tmp_path, capsys):
    f = tmp_path / "g.yaml"
    f.write_text("seed: 1\n")
    code, err = run(capsys, "generate", "--config", str(f), "--scenario", "smoke", "--out", str(tmp_path / "ds"))
    assert code == 2 and any("--config or --scenario" in ln for ln in err)


def test_flags_win_over_the_file_and_metadata_records_the_resolved_whole(tmp_path, capsys):
    f = tmp_path / "g.yaml"
    f.write_text("scene: {name: indoor, lighting: 0.5}\nrig: stereo27\nduration_s: 30\nseed: 1\nformat: both\n"
                 "depth: true\nnoise: {image_sigma: 3}\nmotion: {vibration_yaw_deg: 0.2}\n")
    out = tmp_path / "a"
    code, err = run(capsys, "generate", "--config", str(f), "--duration", "0.5", "--seed", "2", "--format", "euroc",
                    "--no-depth", "--no-images", "--no-progress", "--set", "noise.image_sigma=0.5",
                    "--set", "baseline=0.2", "--out", str(out))
    assert code == 0, err
    meta = yaml.safe_load((out / "metadata.yaml").read_text())
    c = meta["config"]
    assert (c["duration_s"], c["seed"], c["format"], c["depth"], c["images"]) == (0.5, 2, "euroc", False, False)
    assert c["scene"]["name"] == "indoor" and c["scene"]["lighting"] == 0.5 and c["scene"]["seed"] is None
    assert c["motion"]["vibration_yaw_deg"] == 0.2 and c["noise"]["image_sigma"] == 0.5
    assert meta["scene"]["seed"] == 2 and meta["image_noise_sigma"] == 0.5
    # the recorded config is the whole: read back, it is the config that was run (same hash) ...
    again = tmp_path / "again.yaml"
    again.write_text(yaml.safe_dump(c))
    cfg = load_generate_config(again)
    assert cfg.config_hash() == meta["config_hash"] and cfg.rig.name == "stereo27"
    assert cfg.rig.baseline == pytest.approx(0.2, abs=1e-15)
    # ... and generating from it alone gives the same bytes
    code, err = run(capsys, "generate", "--config", str(again), "--no-progress", "--out", str(tmp_path / "b"))
    assert code == 0, err
    assert digest(out) == digest(tmp_path / "b")


@pytest.mark.parametrize("argv", [
    ["check", "--estimator", "rop", "--scenario", "smoke", "--max-drift", "5", "--set", "scene.texture=0.2"],
    ["consistency", "--estimator", "rop", "--scenario", "smoke", "--set", "scene.texture=0.2", "--out", "{tmp}/c"],
])
def test_scenario_commands_check_set_before_generating(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "cache"))
    code, err = run(capsys, *[a.replace("{tmp}", str(tmp_path)) for a in argv])
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("error: --set 'scene.texture=0.2': scene.texture: unknown key; valid keys: scene.name")
    assert not (tmp_path / "cache").exists() and not (tmp_path / "c").exists()


def test_flags_apply_together_over_the_file(tmp_path, capsys):
    """A file with images: false and format euroc; --format kitti alone would be invalid with it, with --images
    the whole is valid. (The run is not started: --out names an existing file, refused before writing.)"""
    from sim.app.cli.cmd_generate import build_config, generate
    f = tmp_path / "g.yaml"
    f.write_text("images: false\nformat: euroc\nduration_s: 1\n")
    ctx = generate.make_context("generate", ["--config", str(f), "--format", "kitti", "--images", "--out", "x"])
    p = ctx.params
    flags = {k: p[k] for k in ("scene", "rig", "duration", "seed", "fmt", "depth", "depth_format", "segmentation",
                               "ideal", "images", "rgb")}
    cfg = build_config(ctx, None, str(f), flags, ())
    assert cfg.format == "kitti" and cfg.images and cfg.duration_s == 1.0
    code, err = run(capsys, "generate", "--config", str(f), "--format", "kitti", "--out", str(tmp_path / "ds"))
    assert code == 2 and len(err) == 1 and "images: false (--no-images) with format 'kitti'" in err[0], err
