"""A world saved by one process and loaded by another (sim.world_handoff) renders the bytes of a freshly built
one; a wrong rig or a missing file is a one-line SimError."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sim.errors import SimError
from sim.generate import resolve
from sim.generate_config import GenerateConfig
from sim.world import build_world
from sim.world_handoff import WorldFiles, load_world, save_world

ROOT = Path(__file__).resolve().parents[1]
CFG = GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.5, seed=3)

CHILD = """
import sys
import numpy as np
from sim.generate import resolve
from sim.generate_config import GenerateConfig
from sim.sensors.camera import StereoCamera
from sim.world_handoff import WorldFiles, load_world
cfg = GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.5, seed=3)
s = resolve(cfg)
world = load_world(WorldFiles(sys.argv[1], cfg.config_hash()), s.scene, s.rig) if sys.argv[2] == "load" else None
T = s.trajectory.states(s.frame_t_ns).T_w_b
with StereoCamera(s.scene, s.rig, vehicle=cfg.vehicle, depth=True, world=world) as cam:
    images, depth, _ = cam.measure(T[3], s.scene.actor_states(int(s.frame_t_ns[3])))
np.savez(sys.argv[3], left=images[0], right=images[1], depth=depth[0])
"""


@pytest.mark.slow
def test_a_saved_world_renders_the_bytes_of_a_built_one(tmp_path):
    """The world saved here, loaded in another process, against one built there: same images and depth."""
    s = resolve(CFG)
    save_world(build_world(s.scene, s.rig, vehicle=CFG.vehicle), tmp_path, CFG.config_hash())
    out = {}
    for mode in ("load", "build"):
        subprocess.run([sys.executable, "-c", CHILD, str(tmp_path), mode, str(tmp_path / f"{mode}.npz")],
                       cwd=ROOT, check=True)
        out[mode] = np.load(tmp_path / f"{mode}.npz")
    for key in ("left", "right", "depth"):
        assert out["load"][key].std() > 0 and np.array_equal(out["load"][key], out["build"][key])


def test_a_saved_world_refuses_another_rig_and_missing_files(tmp_path):
    s = resolve(CFG)
    files = save_world(build_world(s.scene, s.rig, vehicle=CFG.vehicle), tmp_path, CFG.config_hash())
    other = resolve(CFG.with_overrides(["rig=cart27"]))
    with pytest.raises(SimError, match="carries rig 'stereo27', not 'cart27'"):
        load_world(files, other.scene, other.rig)
    with pytest.raises(SimError, match="cannot load the saved world") as err:
        load_world(WorldFiles(str(tmp_path / "nothing"), files.key), s.scene, s.rig)
    assert "\n" not in str(err.value)
    world = load_world(files, s.scene, s.rig)
    built = build_world(s.scene, s.rig, vehicle=CFG.vehicle)
    assert world.model.ngeom == built.model.ngeom > 10 and world.camera_ids == built.camera_ids


@pytest.mark.slow
def test_worker_rendered_chunks_equal_the_writing_process_render(tmp_path):
    """ChunkSource with the writing process kept out of rendering (render_here=False): every chunk comes from
    the two worker processes (which load the saved world once it is ready) and equals, frame for frame, the
    chunk rendered in this process from a freshly built world (the serial path and the writing process's own)."""
    from sim.render_workers import ChunkSource, render_chunk
    cfg = CFG.with_overrides(["depth=true", "segmentation=true", "camera.vignetting=0.3"])
    n = len(resolve(cfg).frame_t_ns)
    with ChunkSource(cfg, 2, resolve, render_here=False) as source:
        chunks = list(source.chunks(0, n, size=4))
    assert source.here == 0 and not any(c.here for c in chunks)
    assert n == 11 and [c.start for c in chunks] == [0, 3, 6, 9]       # at least two chunks per worker
    here = render_chunk(cfg, 0, n, resolve)
    got = [f for c in chunks for f in c.frames]
    assert len(got) == n == len(here.frames) > 5 and chunks[0].geom_names == here.geom_names
    for (imgs, depth, seg), (imgs0, depth0, seg0) in zip(got, here.frames):
        assert all(np.array_equal(a, b) for a, b in zip(imgs, imgs0))
        assert np.array_equal(np.asarray(depth), np.asarray(depth0)) and np.array_equal(np.asarray(seg), np.asarray(seg0))
        assert np.asarray(depth).size and np.asarray(seg).size
