"""Each scene compiles in MuJoCo, keeps its route corridor free, renders sane, textured images."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from sim.rng import scene_streams  # noqa: E402
from scenes import SceneConfig, make_scene  # noqa: E402
from scenes.routes import point_at, resample  # noqa: E402

POSES_S = {"campus": 2.0, "indoor": 4.5}     # arc length (m) of the test camera along the route


def build(name, richness, seed=0):
    """Scene + compiled model with cameras at 1.2 m on the route looking along it."""
    sc = make_scene(SceneConfig(name=name, seed=seed, texture_richness=richness), scene_streams(seed))
    spec = mujoco.MjSpec()
    sc.add_to_spec(spec)
    spec.visual.quality.offsamples = 0
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 752, 480
    p = point_at(sc.path_xy, [POSES_S[name], POSES_S[name] + 0.3], closed=sc.route.closed)
    t = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
    # MuJoCo camera axes in world: x right = (t_y, -t_x, 0), y up = z, looks along -z = forward t
    R_w_cam = np.column_stack([[t[1], -t[0], 0], [0, 0, 1], [-t[0], -t[1], 0]])
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, R_w_cam.ravel())
    spec.worldbody.add_camera(name="test_cam", pos=[p[0, 0], p[0, 1], 1.2], quat=q, fovy=55)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return sc, model, data


def render(model, data, h, w):
    with mujoco.Renderer(model, h, w) as r:
        r.update_scene(data, camera="test_cam")
        return r.render()


def corners(img):
    g = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    c = cv2.goodFeaturesToTrack(g, 3000, 0.01, 7)
    return 0 if c is None else len(c)


@pytest.fixture(scope="module", params=["campus", "indoor"])
def rich(request):
    return build(request.param, 1.0)


def world_aabbs(model, data):
    """(ngeom, 2, 3) world-frame min/max corners of every geom's AABB (planes excluded: inf)."""
    out = np.full((model.ngeom, 2, 3), np.inf)
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    for g in range(model.ngeom):
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        pts = data.geom_xpos[g] + (c + signs * h) @ data.geom_xmat[g].reshape(3, 3).T
        out[g] = pts.min(0), pts.max(0)
    return out


def test_route_corridor_is_free(rich):
    sc, model, data = rich
    wp = sc.route.xy
    dense = resample(np.vstack([wp, wp[:1]]) if sc.route.closed else wp, 0.05)
    boxes = world_aabbs(model, data)
    hw, hz = sc.corridor_half_width_m, sc.corridor_height_m
    checked = 0
    for g in range(model.ngeom):
        lo, hi = boxes[g]
        if not np.isfinite(lo).all() or hi[2] <= 0.05 or lo[2] >= hz:   # ground slabs / ceiling
            continue
        d = np.linalg.norm(np.maximum(np.maximum(lo[:2] - dense, 0), dense - hi[:2]), axis=1).min()
        assert d >= hw, f"{mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)} {d:.2f} m from route"
        checked += 1
    assert checked > 50


def test_names_and_object_ids(rich):
    sc, model, _ = rich
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(model.ngeom)]
    assert all(n.startswith("static/") for n in names)
    ids = sc.object_ids()
    assert sorted(ids) == sorted(names) and sorted(ids.values()) == list(range(1, len(names) + 1))


def test_render_exposure_and_texture(rich):
    sc, model, data = rich
    small = render(model, data, 120, 160)
    assert small.shape == (120, 160, 3)
    assert 60 < small.mean() < 200                           # well exposed, not black or blown out
    assert (small.reshape(-1, 3) >= 250).all(axis=1).mean() < 0.05
    n_rich = corners(render(model, data, 480, 752))
    assert n_rich >= 100
    _, model0, data0 = build(sc.name, 0.0)
    n_flat = corners(render(model0, data0, 480, 752))
    assert n_flat < 0.4 * n_rich                             # texture-poor: far fewer corners


def test_texture_memory_modest(rich):
    sc, model, _ = rich
    assert sc.texture_bytes < 40e6 and model.tex_data.nbytes < 40e6


def test_same_config_same_model_other_seed_differs():
    _, m1, _ = build("indoor", 0.7, seed=5)
    _, m2, _ = build("indoor", 0.7, seed=5)
    _, m3, _ = build("indoor", 0.7, seed=6)
    assert m1.tex_data.tobytes() == m2.tex_data.tobytes()
    assert np.array_equal(m1.geom_pos, m2.geom_pos)
    assert np.array_equal(m1.mesh_vert, m2.mesh_vert)
    assert m1.tex_data.tobytes() != m3.tex_data.tobytes()


def test_lighting_scales_brightness():
    sc = make_scene(SceneConfig(name="indoor", lighting=0.5), scene_streams(0))
    spec = mujoco.MjSpec()
    sc.add_to_spec(spec)
    m = spec.compile()
    # headlight ambient and light diffuse scale linearly with the knob (indoor defaults 0.45, 0.35)
    assert m.vis.headlight.ambient[0] == pytest.approx(0.225, abs=1e-6)
    assert m.light_diffuse[0, 0] == pytest.approx(0.175, abs=1e-6)
    assert not m.light_castshadow.any()
    spec = mujoco.MjSpec()
    make_scene(SceneConfig(name="indoor", shadows=True), scene_streams(0)).add_to_spec(spec)
    assert spec.compile().light_castshadow.all()
