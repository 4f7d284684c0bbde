"""The texture store gives the bytes a fresh draw gives, survives damage and concurrent writers."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import mujoco
import numpy as np
import pytest

from scenes.builder import SceneBuilder
from scenes.texture_store import TextureStore
from scenes.textures import make_texture, weather
from sim.rng import scene_streams

ROOT = Path(__file__).resolve().parents[1]


def _draw(streams, kind="brick", part="wall0"):
    return weather(make_texture(kind, streams(f"texture/{kind}/{part}"), 0.8, 64),
                   streams(f"texture/weather/{part}"), stickers=True)


def _get(store, streams, kind="brick", part="wall0", calls=None):
    def draw():
        if calls is not None:
            calls.append(1)
        return _draw(streams, kind, part)
    keys = (f"texture/{kind}/{part}", f"texture/weather/{part}")
    return store.get(tuple(streams(k) for k in keys), ("instance", kind, 0.8, 64, True), draw)


def test_a_hit_returns_the_bytes_of_a_fresh_draw(tmp_path):
    streams, calls = scene_streams(5), []
    store = TextureStore(tmp_path)
    first = _get(store, streams, calls=calls)
    again = _get(TextureStore(tmp_path), streams, calls=calls)   # a new process's store: read from disk
    assert len(calls) == 1
    np.testing.assert_array_equal(first, _draw(streams))
    np.testing.assert_array_equal(again, first)
    assert again.dtype == np.uint8 and again.shape == (64, 64, 3)


def test_the_key_follows_stream_state_and_parameters(tmp_path):
    store = TextureStore(tmp_path)
    a, b = scene_streams(5), scene_streams(6)
    rng = (a("texture/brick/wall0"),)
    assert store.key(rng, ("x", 1)) == store.key((a("texture/brick/wall0"),), ("x", 1))
    assert store.key(rng, ("x", 1)) != store.key((b("texture/brick/wall0"),), ("x", 1))      # other seed
    assert store.key(rng, ("x", 1)) != store.key((a("texture/brick/wall1"),), ("x", 1))      # other stream
    assert store.key(rng, ("x", 1)) != store.key(rng, ("x", 2))                                # other params
    np.testing.assert_array_equal(_get(store, b), _draw(b))
    assert not np.array_equal(_get(store, a), _get(store, b))


def test_a_damaged_file_is_drawn_again(tmp_path):
    streams, calls = scene_streams(1), []
    store = TextureStore(tmp_path)
    _get(store, streams, calls=calls)
    (path,) = list(tmp_path.rglob("*.npy"))
    path.write_bytes(path.read_bytes()[:100])                       # truncated, as by a full disk
    np.testing.assert_array_equal(_get(store, streams, calls=calls), _draw(streams))
    assert len(calls) == 2
    np.testing.assert_array_equal(np.load(path), _draw(streams))   # replaced by a whole file


def test_no_store_keeps_nothing(tmp_path):
    store = TextureStore(None)
    np.testing.assert_array_equal(_get(store, scene_streams(2)), _draw(scene_streams(2)))
    assert store.hits == store.misses == 0


def test_a_builder_with_a_store_compiles_the_same_model(tmp_path):
    def build(store):
        spec = mujoco.MjSpec()
        b = SceneBuilder(spec, scene_streams(3), 0.8, tex_size=64, textures=store)
        mat = b.instance_material(b.material("brick"), "wall", area_m2=20.0)
        b.instance_material(b.material("plaster", variant=1), "post", area_m2=1.0)
        b.poor_material("white")
        spec.worldbody.add_geom(size=[1, 1, 1], material=mat)
        return spec.compile()
    cold = build(TextureStore(tmp_path))
    warm_store = TextureStore(tmp_path)
    warm, plain = build(warm_store), build(None)
    assert warm_store.hits == 3 and warm_store.misses == 0
    for m in (warm, plain):
        np.testing.assert_array_equal(m.tex_data, cold.tex_data)


def test_concurrent_processes_write_one_whole_texture(tmp_path):
    code = textwrap.dedent(f"""
        import sys, numpy as np
        sys.path.insert(0, {str(ROOT)!r})
        from scenes.texture_store import TextureStore
        from scenes.textures import make_texture
        from sim.rng import scene_streams
        s = scene_streams(9)
        img = TextureStore({str(tmp_path)!r}).get((s("texture/brick/0"),), ("shared", 256),
                                                  lambda: make_texture("brick", s("texture/brick/0"), 0.8, 256))
        sys.stdout.write(str(int(img.astype(np.int64).sum())))
    """)
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE) for _ in range(4)]
    sums = {p.communicate(timeout=120)[0].decode() for p in procs}
    assert all(p.returncode == 0 for p in procs)
    s = scene_streams(9)
    expect = make_texture("brick", s("texture/brick/0"), 0.8, 256)
    assert sums == {str(int(expect.astype(np.int64).sum()))}
    files = list(tmp_path.rglob("*.npy"))
    assert len(files) == 1 and not list(tmp_path.rglob("*.tmp*"))
    np.testing.assert_array_equal(np.load(files[0]), expect)


@pytest.mark.parametrize("off", ["0", "off"])
def test_the_environment_turns_the_machine_store_off(monkeypatch, tmp_path, off):
    from sim.texture_cache import texture_store
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path))
    assert texture_store().root == tmp_path / "textures"
    monkeypatch.setenv("VO_TESTBED_TEXTURE_CACHE", off)
    assert texture_store().root is None
