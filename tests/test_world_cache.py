"""The machine's world cache (sim.world_cache): a hit gives the dataset bytes of a fresh build (serial and with
worker processes); every world-relevant change of the configuration misses, other changes hit; a damaged or
partial entry is rebuilt; concurrent real processes leave one whole entry and the same bytes; the code digest
covers the builder's import closure; least recently used entries are evicted beyond the limit."""
import ast
import dataclasses
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sim.generate_config import GenerateConfig
from sim.world_cache import (CODE_FILES, CODE_TREES, ENTRY_FILES, MANIFEST, WorldCache, verify, world_cache,
                             world_key)

ROOT = Path(__file__).resolve().parents[1]
SHORT = GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.5, seed=3)


def digest(path):
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*")) if p.is_file()}


def entries(root):
    return sorted(p.name for p in Path(root).iterdir() if not p.name.startswith("."))


def _key(cfg):
    return world_key(cfg, cfg.rig, cfg.vehicle)


@pytest.mark.slow
def test_a_cache_hit_writes_the_bytes_of_a_fresh_build(tmp_path, monkeypatch):
    """No cache (a fresh build), then a miss that stores the world, then hits serially and with 2 render
    processes: one SHA-256 over every file (images, depth, segmentation and its ids, top-down map, metadata)."""
    from sim.generate import generate
    from sim.stage_timer import StageTimer
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path / "cache"))
    cfg = SHORT.with_overrides(["depth=true", "segmentation=true"])
    runs = {}
    for name, workers, switch in (("fresh", 1, "0"), ("miss", 1, "1"), ("hit", 1, "1"), ("workers-hit", 2, "1")):
        monkeypatch.setenv("VO_TESTBED_WORLD_CACHE", switch)
        timer = StageTimer()
        generate(cfg, tmp_path / name, progress=False, workers=workers, timer=timer)
        runs[name] = ({k for k in timer.totals() if k.startswith("world cache ")}, digest(tmp_path / name))
    assert [runs[n][0] for n in runs] == [{"world cache off"}, {"world cache miss"}, {"world cache hit"},
                                          {"world cache hit"}]
    fresh = runs["fresh"][1]
    assert len(fresh) > 40 and "topdown.png" in fresh
    assert all(runs[n][1] == fresh for n in runs)
    worlds = tmp_path / "cache" / "worlds"
    assert entries(worlds) == [_key(cfg)] and verify(worlds / _key(cfg), _key(cfg))
    assert not [p for p in worlds.iterdir() if p.name not in (".lock", _key(cfg))]   # no checkout or stage left


def test_world_relevant_changes_miss_and_others_hit(tmp_path, monkeypatch):
    base = _key(SHORT)
    assert len(base) == 64 and base == _key(GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.5, seed=3))
    for items in (["seed=4"], ["scene.seed=9"], ["scene.texture_richness=0.5"], ["scene.lighting=0.9"],
                  ["scene.shadows=true"], ["vehicle=car"], ["rig=cart27"], ["scene.name=campus"]):
        assert _key(SHORT.with_overrides(items)) != base, items
    for items in (["duration_s=0.3"], ["noise.image_sigma=3"], ["render.png_compression=3"], ["depth=true"],
                  ["motion.cruise_speed_mps=0.8"], ["camera.vignetting=0.3"]):
        assert _key(SHORT.with_overrides(items)) == base, items
    cams = SHORT.rig.cameras
    moved = dataclasses.replace(SHORT.rig, cameras=(dataclasses.replace(cams[0], fx=cams[0].fx + 1e-9),) + cams[1:])
    assert world_key(SHORT, moved, SHORT.vehicle) != base           # a rig's intrinsics, to the last bit
    # a scene without actors never sees the dataset seed; one with actors draws them from it
    static = GenerateConfig(scene="campus", rig="stereo27", seed=1).with_overrides(["scene.seed=5"])
    assert _key(static) == _key(static.with_overrides(["seed=2"]))
    urban = GenerateConfig(scene="urban", rig="stereo27", seed=1).with_overrides(["scene.seed=5"])
    assert _key(urban) != _key(urban.with_overrides(["seed=2"]))
    (tmp_path / "plugin_scene_wc.py").write_text("from scenes.indoor import IndoorScene\n\n\n"
                                                 "class Indoor2(IndoorScene):\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugin = SHORT.with_overrides(["scene.name=plugin_scene_wc:Indoor2"])     # its code is not digested: never cached
    assert world_key(plugin, SHORT.rig, "cart") is None


def test_the_code_digest_covers_the_builders_import_closure():
    """Every project module that the world's build imports (statically, function-level imports too) is digested."""
    digested = {p.relative_to(ROOT) for t in CODE_TREES for p in (ROOT / t).rglob("*.py")}
    digested |= {Path(f) for f in CODE_FILES}
    todo, seen = ["sim.world", "sim.world_handoff", "scenes.registry", "sim.rng"], {}
    while todo:
        name = todo.pop()
        path = next((p for p in (ROOT / (name.replace(".", "/") + ".py"), ROOT / name.replace(".", "/") / "__init__.py")
                     if p.exists()), None)
        if name in seen or path is None:
            continue
        seen[name] = path.relative_to(ROOT)
        if name == "sim":                   # the package's lazy sim.streaming import is not the builder's
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            mods = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module] + [f"{node.module}.{a.name}" for a in node.names] \
                if isinstance(node, ast.ImportFrom) and node.module and not node.level else []
            for m in mods:
                if m.split(".")[0] in ("sim", "rigs", "scenes", "vo"):
                    parts = m.split(".")
                    todo += [".".join(parts[:i]) for i in range(1, len(parts) + 1)]
    assert len(seen) > 30 and set(seen.values()) <= digested, set(seen.values()) - digested


@pytest.mark.slow
def test_a_damaged_or_partial_entry_is_a_miss_and_is_rebuilt(tmp_path):
    from sim.generate import resolve
    cache, s = WorldCache(tmp_path), resolve(SHORT)
    key = _key(SHORT)
    world, source = cache.world(SHORT, s.scene, s.rig, SHORT.vehicle)
    assert source == "miss" and verify(tmp_path / key, key)
    good = digest(tmp_path / key)
    model = tmp_path / key / ENTRY_FILES[0]
    for damage in ("flip", "truncate", "no manifest", "manifest of another key"):
        entry = tmp_path / key
        if damage == "flip":
            data = bytearray(model.read_bytes())
            data[len(data) // 2] ^= 1
            model.write_bytes(bytes(data))
        elif damage == "truncate":
            model.write_bytes(model.read_bytes()[:1000])
        elif damage == "no manifest":
            (entry / MANIFEST).unlink()
        else:
            m = json.loads((entry / MANIFEST).read_text())
            (entry / MANIFEST).write_text(json.dumps({**m, "key": "0" * 64}))
        assert not verify(entry, key) and cache.checkout(key) is None, damage
        again, source = cache.world(SHORT, resolve(SHORT).scene, s.rig, SHORT.vehicle)
        assert source == "miss" and digest(entry) == good, damage       # rebuilt: the same bytes again
        assert again.model.ngeom == world.model.ngeom
    assert cache.world(SHORT, resolve(SHORT).scene, s.rig, SHORT.vehicle)[1] == "hit"
    assert entries(tmp_path) == [key] and [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == [".lock"]


def test_the_switch_turns_the_cache_off(tmp_path, monkeypatch):
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path))
    monkeypatch.setenv("VO_TESTBED_WORLD_CACHE", "0")
    assert world_cache().root is None and world_cache().checkout(_key(SHORT)) is None
    assert not world_cache().publish(_key(SHORT), tmp_path)
    monkeypatch.setenv("VO_TESTBED_WORLD_CACHE", "1")
    assert world_cache().root == tmp_path / "worlds"


def _fake_world(folder, size):
    folder.mkdir()
    for name in ENTRY_FILES:
        (folder / name).write_bytes(os.urandom(size))
    return folder


def test_least_recently_used_entries_are_evicted_beyond_the_limit(tmp_path):
    cache = WorldCache(tmp_path / "worlds", limit_mb=2.5)          # room for two 1 MB entries
    keys = [c * 64 for c in "abc"]
    for i, key in enumerate(keys[:2]):
        assert cache.publish(key, _fake_world(tmp_path / f"w{i}", 2 ** 19))    # linked: w0, w1 stay
        os.utime(tmp_path / "worlds" / key, (time.time() - 100 + i, time.time() - 100 + i))
    folder = cache.checkout(keys[0])              # a read makes "a" the most recently used
    assert folder is not None and sorted(os.listdir(folder)) == sorted(ENTRY_FILES + (MANIFEST,))
    assert cache.publish(keys[2], _fake_world(tmp_path / "w2", 2 ** 19))
    assert entries(tmp_path / "worlds") == [keys[0], keys[2]]      # "b", least recently used, is gone
    assert (tmp_path / "w0" / ENTRY_FILES[0]).exists() and verify(folder, keys[0])   # the checkout is intact
    assert cache.publish(keys[2], _fake_world(tmp_path / "w3", 10))     # a whole entry there is kept
    assert (tmp_path / "worlds" / keys[2] / ENTRY_FILES[0]).stat().st_size == 2 ** 19


CHILD = """
import hashlib, sys, time
from pathlib import Path
from sim.generate import generate
from sim.generate_config import GenerateConfig
from sim.stage_timer import StageTimer
while not Path(sys.argv[2]).exists():              # start together: every process misses
    time.sleep(0.01)
timer = StageTimer()
cfg = GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.2, seed=3)
generate(cfg, sys.argv[1], progress=False, threads=0, timer=timer)
print(*[k for k in timer.totals() if k.startswith("world cache ")])
"""


@pytest.mark.slow
def test_concurrent_generate_runs_share_one_whole_entry(tmp_path):
    """Three real processes generate the same configuration at once into an empty cache: they build (at least
    two miss), one entry is left, whole, and all three datasets, and a later run's from the entry, are the same."""
    env = {**os.environ, "VO_TESTBED_CACHE": str(tmp_path / "cache"), "VO_TESTBED_WORLD_CACHE": "1",
           "PYTHONPATH": str(ROOT)}
    go = tmp_path / "go"
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path / f"run{i}"), str(go)], cwd=ROOT, env=env,
                              stdout=subprocess.PIPE, text=True) for i in range(3)]
    time.sleep(1.0)
    go.touch()
    outs = [p.communicate(timeout=600)[0].strip() for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0] and set(outs) <= {"world cache miss", "world cache hit"}
    assert outs.count("world cache miss") >= 2          # at least two built and stored the world at once
    later = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path / "later"), str(go)], cwd=ROOT, env=env,
                           stdout=subprocess.PIPE, text=True, check=True).stdout.strip()
    assert later == "world cache hit"
    d = [digest(tmp_path / f"run{i}") for i in range(3)] + [digest(tmp_path / "later")]
    assert len(d[0]) > 20 and all(x == d[0] for x in d)
    worlds = tmp_path / "cache" / "worlds"
    key = _key(GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.2, seed=3))
    assert entries(worlds) == [key] and verify(worlds / key, key)
    assert [p.name for p in worlds.iterdir() if p.name.startswith(".")] == [".lock"]


@pytest.mark.parametrize("value", ["lots", "-1", "nan", "inf"])
def test_a_bad_size_limit_is_a_one_line_error_before_anything_is_written(tmp_path, monkeypatch, value):
    from sim.errors import SimError
    from sim.generate import generate
    monkeypatch.setenv("VO_TESTBED_WORLD_CACHE_MB", value)
    with pytest.raises(SimError, match=f"VO_TESTBED_WORLD_CACHE_MB: expected a number of megabytes >= 0, "
                                       f"got '{value}'"):
        generate(SHORT, tmp_path / "ds", progress=False)
    assert not (tmp_path / "ds").exists()


def test_a_bad_size_limit_through_the_console_is_exit_2_and_one_line(tmp_path, monkeypatch, capsys):
    from sim.app.cli import main
    monkeypatch.setenv("VO_TESTBED_WORLD_CACHE_MB", "lots")
    with pytest.raises(SystemExit) as exit_:
        main(["generate", "--scenario", "smoke", "--out", str(tmp_path / "ds")])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and err.count("\n") == 0 and "Traceback" not in err
    assert "VO_TESTBED_WORLD_CACHE_MB: expected a number of megabytes >= 0, got 'lots'" in err
    assert not (tmp_path / "ds").exists()
