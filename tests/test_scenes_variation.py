"""Every textured surface instance has its own seeded look (no look-alike places), actors wear vehicle and
clothing atlases, and the validations that measure both: corner density by region and ORB place similarity."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from scenes.actor_textures import LAYOUTS, actor_atlas, cell_uv  # noqa: E402
from scenes.errors import SceneError  # noqa: E402
from scenes.textures import make_texture, weather  # noqa: E402
from sim.rng import scene_streams  # noqa: E402


def test_weather_seeded_and_changes_every_instance():
    base = make_texture("brick", scene_streams(0)("texture/brick/0"), 0.8, 64)
    a = weather(base, scene_streams(0)("texture/weather/a"))
    assert a.tobytes() == weather(base, scene_streams(0)("texture/weather/a")).tobytes()
    b = weather(base, scene_streams(0)("texture/weather/b"))
    assert a.shape == base.shape and a.dtype == np.uint8
    # another instance: a visibly different image (mean absolute difference of several grey levels)
    assert np.abs(a.astype(int) - b.astype(int)).mean() > 3.0
    with pytest.raises(SceneError):
        weather(base[:, :32], scene_streams(0)("texture/weather/a"))


@pytest.mark.parametrize("kind", sorted(LAYOUTS))
def test_actor_atlas_seeded_smooth_paint(kind):
    import cv2
    a = actor_atlas(kind, scene_streams(3)(f"texture/urban-actor/{kind}/0"))
    (W, H), cells = LAYOUTS[kind]
    assert a.shape == (H, W, 3) and a.dtype == np.uint8
    assert a.tobytes() == actor_atlas(kind, scene_streams(3)(f"texture/urban-actor/{kind}/0")).tobytes()
    # paint / clothes: one smooth colour, mild gradient and grain (no pattern): a small spread and no corner
    name = {"car": "paint", "bus": "paint", "pedestrian": "hair"}[kind]
    x0, y0, w, h = cells[name]
    cell = a[y0 + 2:y0 + h - 2, x0 + 2:x0 + w - 2].astype(float)
    assert cell.std(axis=(0, 1)).max() < 10.0
    # corner strength (Shi-Tomasi's min eigenvalue): the paint has none of the front's (lights, windows, face)
    def strength(c):
        x0, y0, w, h = cells[c]
        g = cv2.cvtColor(np.ascontiguousarray(a[y0 + 2:y0 + h - 2, x0 + 2:x0 + w - 2]), cv2.COLOR_RGB2GRAY)
        return float(cv2.cornerMinEigenVal(g.astype(np.float32), 3).max())
    front = {"car": "front", "bus": "front", "pedestrian": "face"}[kind]
    assert strength(name) < 0.05 * strength(front)
    with pytest.raises(SceneError):
        actor_atlas("tram", scene_streams(3)("texture/x/0"))


def test_cell_uv_stays_inside_the_cell():
    (W, H), cells = LAYOUTS["car"]
    x0, y0, w, h = cells["tyre"]
    u, v = cell_uv("car", "tyre", np.array([0.0, 1.0]), np.array([0.0, 1.0]))
    assert np.all(u * W > x0) and np.all(u * W < x0 + w) and np.all(v * H > y0) and np.all(v * H < y0 + h)
    with pytest.raises(SceneError, match="no cell"):
        cell_uv("car", "wing", 0.5, 0.5)


def _texture_of_geoms(model):
    """geom id -> (texture id, rgba) of its material (-1 when untextured)."""
    import mujoco
    out = {}
    for g in range(model.ngeom):
        m = model.geom_matid[g]
        if m < 0:
            continue
        tex = int(model.mat_texid[m, int(mujoco.mjtTextureRole.mjTEXROLE_RGB)])
        out[g] = (tex, tuple(np.round(model.mat_rgba[m], 4)))
    return out


@pytest.mark.parametrize("name", ["campus", "indoor"])
def test_every_textured_instance_has_its_own_look(name):
    """No two textured geoms share both texture and colour; geoms of the same shared material differ. (An indoor
    wall side is one surface in pieces, split by its doors: its pieces show their own parts of one texture drawn
    at the side's full extent, tests/test_scenes_indoor_walls.py.)"""
    import mujoco
    from scenes import SceneConfig, make_scene
    sc = make_scene(SceneConfig(name=name), scene_streams(0))
    spec = mujoco.MjSpec()
    sc.add_to_spec(spec)
    m = spec.compile()
    wall = {t for t in range(m.ntex) if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXTURE, t).startswith("tex/wall/")}
    looks = [v for v in _texture_of_geoms(m).values() if v[0] >= 0 and v[0] not in wall]
    assert len(looks) > 40
    assert len(set(looks)) == len(looks)
    role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    texs = [int(m.mat_texid[m.geom_matid[g], role]) for g in range(m.ngeom) if m.geom_matid[g] >= 0]
    big = [t for t in texs if t >= 0 and "/i/" in mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXTURE, t)]
    assert len(big) + len(wall) > 10 and len(set(big)) == len(big)            # large surfaces: a texture each


def test_corner_density_counts_by_region():
    """Corners only where the texture is; the labelled regions get them, the sky none."""
    from sim.app.validation.traffic_texture import corner_density
    rng = np.random.default_rng(1)
    H, W = 200, 320
    tex = np.kron((rng.random((H // 8, W // 8)) * 255).astype(np.uint8), np.ones((8, 8), np.uint8))
    img = np.full((H, W), 120, np.uint8)
    img[:, :100] = tex[:, :100]                                      # textured actor on the left
    seg = np.full((H, W), 5, np.int64)                               # static geometry
    seg[:, :100] = 9                                                 # actor id 9
    seg[:40, 100:] = 0                                               # sky
    d = corner_density([img], [seg], {9})
    assert d.actor_corners > 50 and d.actor_px == 100 * H
    assert d.background_px == (W - 100) * H and d.static_px == (W - 100) * (H - 40)
    assert d.background_corners <= 0.05 * d.actor_corners           # only along the 100-px border
    assert d.background_corners == 0 and np.isnan(d.ratio)          # no corner in the background: undefined
    img2 = img.copy()
    img2[100:, 200:] = tex[100:, 200:]                               # texture on part of the static geometry
    d3 = corner_density([img2], [seg], {9})
    assert d3.static_corners > 20 and d3.static_corners == d3.background_corners   # none in the sky
    assert d3.ratio == pytest.approx((d3.actor_corners / d3.actor_px) / (d3.background_corners / d3.background_px))
    assert d3.ratio_static < d3.ratio                                # the sky lowers the background's density
    d2 = corner_density([img], [np.where(seg == 9, 5, seg)], set())  # no actor: everything background
    assert d2.actor_px == 0 and d2.background_corners == d.actor_corners + d.background_corners


@pytest.mark.slow
def test_place_check_separates_revisits_from_distinct_places():
    """Campus at 8 m spacing (11 places): every revisit is far more similar than any pair of distinct places,
    which stays below a loop closure's acceptance; a view and a shifted copy of itself (a look-alike) would be
    accepted, so the measure does see aliasing."""
    from sim.app.validation.place_recognition import (LOOP_ACCEPT_INLIERS, OrbMatcher, PlaceConfig, check_places,
                                                      covisible_fraction, render_views)
    from sim.scenarios import get_scenario
    place = PlaceConfig(spacing_m=8.0)
    places, revisits = render_views(get_scenario("campus"), place, progress=False)
    assert len(places) == 11
    v = places[0]
    assert covisible_fraction(v, v) == pytest.approx(1.0)
    assert covisible_fraction(v, revisits[0]) > 0.3
    res, _ = check_places(places, revisits, "campus", place, progress=False)
    assert len(res.distinct) > 100 and res.passed, res.table()
    m = OrbMatcher(place)
    shifted = np.roll(v.image, 40, axis=1)
    assert m.inliers(m.features(0, v.image), m.features(1, shifted)) > LOOP_ACCEPT_INLIERS


def test_validate_traffic_and_places_bad_input_one_line(capsys, tmp_path):
    """A folder without segmentation, an unknown scenario: exit 2 and one line (docs/bad_input.md)."""
    from sim.app.cli import main

    def run(*args):
        try:
            main(list(args))
            code = 0
        except SystemExit as e:
            code = e.code
        return code, capsys.readouterr().err

    for args, needle in ((("validate", "traffic", "--data", str(tmp_path)), "generate with --segmentation"),
                         (("validate", "places", "--scenario", "nope"), "unknown scenario 'nope'")):
        code, err = run(*args)
        lines = [line for line in err.strip().splitlines() if line.strip()]
        assert code == 2 and "Traceback" not in err and len(lines) == 1 and needle in lines[0], err


def test_every_bus_its_own_body_and_livery():
    """A bus's body and atlas come from its own indexed streams: the same seed and index give the same bytes,
    another index or seed another bus (body, window bays, atlas); every body stays inside the clearance
    footprint and its windows inside the side cell, without overlapping."""
    from scenes.actor_textures import bus_atlas
    from scenes.bus_shapes import BUS_HALF_XY, bus_layout, draw_bus_body

    def bus(seed, k):
        st = scene_streams(seed)
        body = draw_bus_body(st(f"urban/actor-shape/{k}"))
        rng = st(f"texture/urban-actor/bus/{k}")
        layout = bus_layout(rng, body)
        return body, layout, bus_atlas(rng, layout)

    b0, l0, a0 = bus(0, 7)
    b0b, l0b, a0b = bus(0, 7)
    assert b0 == b0b and l0 == l0b and a0.tobytes() == a0b.tobytes()
    others = [bus(0, k) for k in range(8, 40)] + [bus(1, 7)]
    for b, lay, a in others:
        assert a.shape == a0.shape and np.abs(a.astype(int) - a0.astype(int)).mean() > 2.0
        assert b != b0 and lay["decks"] != l0["decks"]
    bays = {tuple(np.round([x for w in lay["decks"][-1][2] for x in w], 2)) for _, lay, _ in others}
    assert len(bays) == len(others)                                        # no two lower decks alike
    assert {b.decks for b, _, _ in others} == {1, 2}
    for b, lay, _ in others + [(b0, l0, a0)]:
        assert b.half_length <= BUS_HALF_XY[0] and b.half_width <= BUS_HALF_XY[1]
        r, _, centres = b.wheels()
        assert all(abs(c[0]) + r < b.half_length for c in centres)
        for fy0, fy1, windows in lay["decks"]:
            assert 0 < fy0 < fy1 < 1
            edges = np.ravel(windows)
            assert np.all(np.diff(edges) > 0) and edges[0] > 0 and edges[-1] < 1


def test_bus_atlas_through_the_texture_store_keyed_by_its_variation(tmp_path):
    """A bus's atlas from the texture store is the bytes a fresh draw gives (a second store on the same folder
    reads it back); its key holds both of its streams, so every bus has its own file and atlas."""
    from types import SimpleNamespace

    from scenes.actor_sheets import actor_look
    from scenes.texture_store import TextureStore
    from scenes.urban import actor_lanes
    from scenes.urban_actors import CAR_PARTS, actor_shape, draw_actors
    from sim.rng import stream
    buses = [a for a in draw_actors(actor_lanes(), 0.0, stream(0, "dynamic")) if a.kind == "bus"][:6]
    assert len(buses) == 6

    def looks(store):
        b = SimpleNamespace(streams=scene_streams(0), textures=store)
        return [actor_look(b, "bus", a.actor_id, actor_shape(b, a, CAR_PARTS[0][1][:2])) for a in buses]
    fresh = looks(TextureStore(None))
    first = TextureStore(tmp_path)
    stored = looks(first)
    again = TextureStore(tmp_path)
    read = looks(again)
    assert first.misses == 6 and again.hits == 6 and again.misses == 0
    assert [x.tobytes() for x in fresh] == [x.tobytes() for x in stored] == [x.tobytes() for x in read]
    assert len({x.tobytes() for x in fresh}) == 6
    assert len(list(tmp_path.rglob("*.npy"))) == 6


def test_place_similarity_counts_distinct_places_of_a_rigid_motion():
    """The similarity of a loop-closure check: features of A (on a plane 10 m ahead, exact depth) seen again from
    a camera moved by a known rigid motion all count; the same features piled onto one pixel of B (the degenerate
    fit PnP RANSAC accepts: a far-away pose) count as the one place they are."""
    import cv2
    from sim.app.validation.place_recognition import OrbMatcher, PlaceConfig, View
    rng = np.random.default_rng(5)
    K = np.array([[400.0, 0, 320], [0, 400.0, 240], [0, 0, 1]])
    n = 80
    xa = np.column_stack([rng.uniform(20, 620, n), rng.uniform(20, 460, n)]).astype(np.float32)
    depth = np.full((480, 640), 10.0)
    view_a = View(np.zeros((480, 640), np.uint8), depth, np.eye(4), K, 0.0)
    des = rng.integers(0, 256, (n, 32), dtype=np.uint8)
    P = (np.linalg.solve(K, np.vstack([xa.T, np.ones(n)])) * 10.0).T
    R, t = cv2.Rodrigues(np.array([0.02, -0.1, 0.01]))[0], np.array([0.5, 0.1, -1.0])
    q = (K @ (R @ P.T + t[:, None])).T
    xb = (q[:, :2] / q[:, 2:]).astype(np.float32)
    m = OrbMatcher(PlaceConfig())
    assert m.inliers((xa, des), (xb, des), view_a=view_a) >= n - 2
    pile = np.tile(np.float32([[300.0, 200.0]]), (n, 1)) + rng.uniform(-0.3, 0.3, (n, 2)).astype(np.float32)
    assert m.inliers((xa, des), (pile, des), view_a=view_a) <= 1


def test_place_views_leave_out_actors_standing_where_the_vehicle_is():
    """An actor whose origin is within ``actor_clear_m`` of a view's vehicle goes 1 km below the ground (the
    camera would be inside it); the others and the input stay as they are."""
    from rigs.geometry import make_T, rot_z
    from sim.app.validation.place_recognition import clear_of_actors
    near, far = make_T(rot_z(0.3), [4.0, 1.0, 0.0]), make_T(np.eye(3), [20.0, -3.0, 0.0])
    actors = {"near": near, "far": far}
    out = clear_of_actors(actors, make_T(rot_z(1.0), [0.5, 0.0, 0.0]), 9.0)
    assert out["near"][2, 3] == -1000.0 and np.array_equal(out["near"][:2], near[:2])
    assert np.array_equal(out["far"], far) and actors["near"][2, 3] == 0.0
