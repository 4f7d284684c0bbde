"""The urban scene: it compiles, its route (length, on the road, right-hand traffic), its seeded moving actors
(smooth, reproducible, still at dynamic_density 0, clear of the vehicle), dusk, the actors' ground truth
against the rendered segmentation, and the dynamic-feature counter."""
import numpy as np
import pytest

from scenes import SceneConfig, make_scene
from scenes.routes import distance_to_polyline
from scenes.urban import ROAD_HALF, TURN_RADIUS
from sim.rng import scene_streams, stream


def urban(seed=0, density=1.0, **kw):
    return make_scene(SceneConfig(name="urban", dynamic_density=density, **kw), scene_streams(seed),
                      stream(seed, "dynamic"))


def compiled(scene):
    import mujoco
    spec = mujoco.MjSpec()
    scene.add_to_spec(spec)
    return spec, spec.compile()


@pytest.fixture(scope="module")
def built():
    """(scene, spec, model) of seed 0 at density 1, compiled once for the tests below (~5 s of textures)."""
    sc = urban()
    spec, m = compiled(sc)
    return sc, spec, m


def test_builds_compiles_and_names_actors(built):
    import mujoco
    sc, _, m = built
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(m.ngeom)]
    dyn = [n for n in names if n.startswith("dyn/")]
    assert len(dyn) == len(sc.actors) > 200                     # one mesh geom per actor
    assert all(n.startswith("dyn/urban/actor_") for n in dyn)
    assert m.nmocap == len(sc.actors)
    assert sum(n.startswith("static/building") for n in names) > 100 and m.ngeom < 2000
    assert sc.texture_bytes < 100e6         # ~94 MB: a texture per large surface and road piece, per actor, parked car
    assert m.nmat < 800                     # MuJoCo takes at most 999 with a skybox: actor atlases tiled into sheets
    rows = sc.segmentation_rows(names)
    assert {r[2] for r in rows if r[2] > 0} == {a.actor_id for a in sc.actors}
    assert all(r[3] == "static" and r[2] == -1 for r in rows if r[1].startswith("static/"))


def test_route_length_on_the_road_right_hand_traffic(built):
    sc = built[0]
    xy = sc.path_xy
    r = TURN_RADIUS
    # straight legs 394.75 m and 274.75 m joined by a quarter circle of radius r (step 0.25 m: < 1 cm)
    assert sc.route_length() == pytest.approx(394.75 + 274.75 - 2 * r + np.pi * r / 2, abs=0.01)
    assert 400 <= sc.route_length() <= 1000
    # on the asphalt: inside the main street (|y| < ROAD_HALF) or the cross street (|x| < ROAD_HALF), with
    # the car's half width (0.9 m) to spare
    on_road = (np.abs(xy[:, 1]) < ROAD_HALF - 0.9) | (np.abs(xy[:, 0]) < ROAD_HALF - 0.9)
    assert on_road.all()
    # right-hand traffic: east on the south half of the main street, south on the west half of the cross street
    d = np.diff(xy, axis=0)
    east, south = d[:, 0] > 0.2, d[:, 1] < -0.2
    assert np.all(xy[1:][east, 1] < 0) and np.all(xy[1:][south, 0] < 0)
    # no static geom (other than the road surface, paint and sidewalks) within 1.5 m of the centre line
    for fp in sc.footprints():
        if fp.category in ("path", "ground") or fp.z_range[0] > 3.0:
            continue
        outline = fp.corners_xy() if fp.radius == 0 else np.array([fp.center_xy])
        gap = distance_to_polyline(outline, xy).min() - fp.radius
        assert gap > 1.5, fp.name
    g = sc.gcp_sites
    assert [s.name for s in g] == [f"G0{k}" for k in range(1, 9)]
    assert np.all(distance_to_polyline([(s.x, s.y) for s in g], xy) < 0.01)


def test_actors_seeded_and_density_switches_motion():
    t = np.arange(1_000_000_000, 60_000_000_000, 500_000_000)
    a0, a0b, a1 = urban(0), urban(0), urban(1)
    P = [np.stack([a.poses(t) for a in sc.actors]) for sc in (a0, a0b, a1)]
    np.testing.assert_array_equal(P[0], P[1])                   # same seed: identical poses
    n = min(len(P[0]), len(P[2]))
    assert np.abs(P[0][:n] - P[2][:n]).max() > 1.0               # another seed: other actors
    still = urban(0, density=0.0)
    assert not any(a.moving for a in still.actors)
    for a in still.actors:                                       # nothing moves at density 0
        T = a.poses(t)
        np.testing.assert_array_equal(T, np.broadcast_to(T[0], T.shape))
    # density only switches actors between moving and standing (the draws are shared) ...
    moving = {a.actor_id for a in a0.actors if a.moving}
    assert moving == {a.actor_id for a in a0.actors}
    half = urban(0, density=0.5)
    n_moving = sum(a.moving for a in half.actors)
    assert n_moving == pytest.approx(0.5 * len(a0.actors), abs=1)
    same = {a.actor_id: a for a in a0.actors}
    assert all(a.origin_xy == same[a.actor_id].origin_xy for a in half.actors)


def test_actors_move_smoothly_with_bounded_acceleration():
    sc = urban(3)
    dt = 0.01
    t_ns = (1e9 + np.arange(0, 100.0, dt) * 1e9).astype(np.int64)
    for a in sc.actors:
        p = a.poses(t_ns)[:, :2, 3]
        acc = np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=1) / dt**2
        bound = a.max_accel()
        # second differences of the exact positions: within the analytic bound (+ the O(dt^2 s'''') error
        # and float64 rounding of ~1e3 m positions, 1e-13 m / 1e-4 s^2 = 1e-9 ... 1e-3 m/s^2)
        assert acc.max() <= bound + 2e-3, (a.actor_id, a.kind, acc.max(), bound)
        # vehicles: speed swing dv w <= 0.06 * 12.5 * 0.9 per term, start from rest v / tau = 10 / 7.3;
        # pedestrians: dv w <= 0.06 * 1.6 * 1.8 per term, crossings v^2 / (W / 2) = 1.5^2 / 9.5
        assert bound <= (2.5 if a.kind != "pedestrian" else 0.5)
        s, sd, _ = a.arc((t_ns - 1e9) * 1e-9)
        if a.mode == "line":
            assert sd[0] >= 0 and np.all(sd[1:] > 0)            # never stops or reverses (leads start at rest)
        np.testing.assert_allclose(np.gradient(s, dt)[1:-1], sd[1:-1], atol=1e-3)   # error |s'''| dt^2 / 6


def _outline(T, half, n=12):
    """(N, 4n, 2) world points on the outline of a rectangle of half sizes ``half`` at poses ``T`` (N,4,4)."""
    u = np.linspace(-1, 1, n)
    local = np.concatenate([np.stack([u, np.full(n, s)], 1) for s in (-1, 1)] +
                           [np.stack([np.full(n, s), u], 1) for s in (-1, 1)]) * half
    return np.einsum("nij,kj->nki", T[:, :2, :2], local) + T[:, None, :2, 3]


def _inside(T, half, pts):
    """(N,) any of ``pts`` (N,K,2) inside the rectangle ``half`` at poses ``T``."""
    loc = np.einsum("nji,nkj->nki", T[:, :2, :2], pts - T[:, None, :2, 3])
    return np.any(np.all(np.abs(loc) <= half, axis=2), axis=1)


def _planar(x, y, yaw):
    T = np.tile(np.eye(4), (len(x), 1, 1))
    T[:, 0, 3], T[:, 1, 3] = x, y
    T[:, 0, 0], T[:, 0, 1], T[:, 1, 0], T[:, 1, 1] = np.cos(yaw), -np.sin(yaw), np.sin(yaw), np.cos(yaw)
    return T


def test_footprint_overlap_exact_cases():
    """Separating-axis test at known contacts: side by side 4 m apart (touch at 3.99, not at 4.01); a
    square turned 45 deg whose corner reaches x = c - sqrt(2); a thin bar at 45 deg whose bounding box
    overlaps the unit square while the bar's own normal separates it (0.141 m apart at x = 2.2,
    overlapping at 2.05)."""
    from scenes.urban_actors import footprint_overlap
    one = _planar([0.0], [0.0], [0.0])
    assert footprint_overlap(one, (2, 1), _planar([3.99], [0.0], [0.0]), (2, 1))[0]
    assert not footprint_overlap(one, (2, 1), _planar([4.01], [0.0], [0.0]), (2, 1))[0]
    r2 = np.sqrt(2)
    assert footprint_overlap(one, (2, 1), _planar([2 + r2 - 0.01], [0.0], [np.pi / 4]), (1, 1))[0]
    assert not footprint_overlap(one, (2, 1), _planar([2 + r2 + 0.01], [0.0], [np.pi / 4]), (1, 1))[0]
    assert not footprint_overlap(one, (1, 1), _planar([2.2], [0.0], [np.pi / 4]), (2, 0.05))[0]
    assert footprint_overlap(one, (1, 1), _planar([2.05], [0.0], [np.pi / 4]), (2, 0.05))[0]


def test_footprint_overlap_agrees_with_sampled_outlines():
    """2000 random pairs (fixed seed): where densely sampled outlines intersect, the test says overlap; where
    the rectangles shrunk by 2 % overlap, the sampled outlines of the full ones intersect too."""
    from scenes.urban_actors import footprint_overlap
    rng = np.random.default_rng(7)
    n = 2000
    Ta = _planar(np.zeros(n), np.zeros(n), rng.uniform(-np.pi, np.pi, n))
    Tb = _planar(rng.uniform(-6, 6, n), rng.uniform(-4, 4, n), rng.uniform(-np.pi, np.pi, n))
    ha, hb = np.array([2.2, 0.9]), np.array([1.5, 0.6])
    sampled = _inside(Ta, ha, _outline(Tb, hb, 80)) | _inside(Tb, hb, _outline(Ta, ha, 80))
    sat = footprint_overlap(Ta, ha, Tb, hb)
    assert 200 < sat.sum() < n - 200                      # both outcomes well represented
    assert np.all(sat[sampled])
    assert np.all(sampled[footprint_overlap(Ta, 0.98 * ha, Tb, 0.98 * hb)])


@pytest.mark.parametrize("seed", range(5))
def test_traffic_never_touches_the_vehicle(seed):
    """Along the ``urban-dynamic`` trajectory no car or bus footprint comes within 0.5 m of the car's
    (4.4 m x 1.76 m) at any 50 ms step: the simulator's own check passes (it runs in every generation), and
    so does the sampled-outline check here."""
    from scenes.urban_actors import SHAPES
    from sim.generate import check_clearance
    from sim.motion import VehicleTrajectory
    from sim.scenarios import get_scenario
    from sim.vehicles.car import CAR_HALF_WIDTH_M, CAR_LENGTH_M
    cfg = get_scenario("urban-dynamic", seed=seed)
    sc = make_scene(cfg.scene_config, scene_streams(seed), stream(seed, "dynamic"))
    tr = VehicleTrajectory.from_route(sc.route, sc.ground_height, cfg.motion, stream(seed, "motion"))
    check_clearance(sc, tr, cfg)
    t = np.arange(tr.t0_ns, tr.t1_ns, 50_000_000)
    T = tr.states(t).T_w_b
    ego_half = np.array([CAR_LENGTH_M / 2, CAR_HALF_WIDTH_M]) + 0.5
    for a in sc.actors:
        if a.kind == "pedestrian":
            continue
        Ta = a.poses(t)
        near = np.linalg.norm(Ta[:, :2, 3] - T[:, :2, 3], axis=1) < 15.0
        if not near.any():
            continue
        half = np.array(SHAPES[a.kind][0][0][1][:2])
        hit = _inside(T[near], ego_half, _outline(Ta[near], half)) | \
            _inside(Ta[near], half, _outline(T[near], ego_half))
        assert not hit.any(), (a.actor_id, a.kind, (t[near][hit][0] - tr.t0_ns) * 1e-9)


def test_cruise_speed_into_the_traffic_ahead_is_refused():
    """At 12 m/s the car catches the platoon placed ahead for 10 m/s: a one-line SimError naming
    ``motion.cruise_speed_mps``, the actor and the time; at 6 m/s the route resolves at that peak speed."""
    from sim.errors import SimError
    from sim.generate import resolve
    from sim.scenarios import get_scenario
    with pytest.raises(SimError, match=r"^motion\.cruise_speed_mps: the vehicle reaches urban actor \d+ "
                                       r"\((car|bus)\) \d+\.\d s after the start") as e:
        resolve(get_scenario("urban-dynamic", overrides=("motion.cruise_speed_mps=12",)))
    assert "\n" not in str(e.value)
    setup = resolve(get_scenario("urban-dynamic", overrides=("motion.cruise_speed_mps=6",)))
    assert setup.trajectory.profile.v_peak == 6.0


@pytest.mark.slow
def test_dusk_lighting(built):
    import mujoco
    day = built[1]
    dusk, _ = compiled(urban(density=0.0, time_of_day="dusk"))
    sun = {s: next(lt for lt in spec.lights if lt.name == "static/sun") for s, spec in (("day", day), ("dusk", dusk))}
    assert sun["dusk"].diffuse[0] > sun["dusk"].diffuse[2]                          # warm
    assert np.degrees(np.arcsin(-sun["dusk"].dir[2] / np.linalg.norm(sun["dusk"].dir))) == pytest.approx(8, abs=1)
    assert dusk.visual.headlight.ambient[0] < 0.5 * day.visual.headlight.ambient[0]
    assert mujoco.mjtLightType.mjLIGHT_DIRECTIONAL == sun["dusk"].type


@pytest.mark.slow
def test_actor_truth_matches_rendered_segmentation():
    """The true pose of every actor whose centre projects into the left image lands on that actor's pixels,
    unless something nearer hides it (exactness of ``actor_truth`` against what MuJoCo renders)."""
    import mujoco
    from rigs.presets import get_rig
    from sim.render import StereoRenderer
    from sim.world import build_world
    from scenes.urban_actors import SHAPES
    sc = urban(0)
    rig = get_rig("paper002")
    w = build_world(sc, rig, vehicle="car")
    t_ns = 1_000_000_000 + 20_000_000_000
    T_w_b = np.eye(4)
    T_w_b[:3, 3] = (-250.0, -5.25, 0.0)
    checked = 0
    with StereoRenderer(w, rig, segmentation=True, depth=True) as r:
        fr = r.render(T_w_b, sc.actor_states(t_ns))
        T_w_c = w.T_w_c(0)
        cam = rig.cameras[0]
        seg, depth = fr.seg[0][..., 0], fr.depth[0]
        for a_id, kind, _, T in sc.actor_truth(np.array([t_ns])):
            parts = SHAPES[kind][0]
            centre_a = np.asarray(parts[0][2])                      # centre of the first box, actor frame
            p_w = T[0] @ np.r_[centre_a, 1.0]
            p_c = np.linalg.solve(T_w_c, p_w)[:3]
            if p_c[2] < 1.0 or p_c[2] > 80.0:
                continue
            u, v = cam.fx * p_c[0] / p_c[2] + cam.cx, cam.fy * p_c[1] / p_c[2] + cam.cy
            if not (0 <= u < cam.width - 1 and 0 <= v < cam.height - 1):
                continue
            g = seg[int(round(v)), int(round(u))]
            name = mujoco.mj_id2name(w.model, mujoco.mjtObj.mjOBJ_GEOM, g) if g >= 0 else ""
            reach = np.linalg.norm(parts[0][1])                     # the box's half diagonal
            if name == f"dyn/urban/actor_{a_id}/body":
                checked += 1
            else:                                                   # hidden: something nearer covers it
                assert depth[int(round(v)), int(round(u))] < p_c[2] - 0.1 * reach, (a_id, name)
    assert checked >= 5


def test_dynamic_fraction_counts_features_where_the_texture_is():
    """Texture only in the region labelled moving -> every feature is dynamic; only outside -> none.
    The image is not square, so swapped (x, y) lookups would fail."""
    from rigs.model import Camera
    from sim.app.validation.dynamic_fraction import dynamic_fraction
    rng = np.random.default_rng(0)
    H, W = 240, 400
    camera = Camera(name="cam0", width=W, height=H, fx=300.0, fy=300.0, cx=W / 2 - 0.5, cy=H / 2 - 0.5)
    base = (rng.random((H // 8, W // 8)) * 255).astype(np.uint8)
    tex = np.kron(base, np.ones((8, 8), np.uint8))
    seg = np.ones((H, W), np.int64)
    seg[:, :150] = 7                                               # id 7 = a moving actor, left 150 columns
    for moving_side, expect in ((True, 1.0), (False, 0.0)):
        img = np.full((H, W), 128, np.uint8)
        cols = slice(0, 150) if moving_side else slice(150, W)
        img[:, cols] = tex[:, cols]
        frames = [np.roll(img, k, axis=0) for k in range(3)]        # a little motion to track
        segs = [np.roll(seg, k, axis=0) for k in range(3)]
        res = dynamic_fraction(frames, segs, {7}, camera)
        assert res.n_features > 20 and res.n_frames == 3
        assert res.fraction == pytest.approx(expect, abs=0.02)      # features on the 150-px border may fall either side


def test_parked_cars_are_each_a_car_of_their_own(built):
    """Every parked car has its own mesh (body type and stretch) and texture: no two share extents or texture;
    every body type of scenes.car_shapes appears (seed 0); a body's footprint is its mesh's."""
    import mujoco
    from scenes.car_shapes import BODIES, CarBody, draw_body
    _, _, m = built
    role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(m.ngeom)]
    cars = [g for g, n in enumerate(names) if n.startswith("static/parked")]
    assert len(cars) > 30
    meshes = [int(m.geom_dataid[g]) for g in cars]
    texs = [int(m.mat_texid[m.geom_matid[g], role]) for g in cars]
    assert len(set(meshes)) == len(cars) and len(set(texs)) == len(cars)
    extents = set()
    for mid in meshes:
        v = m.mesh_vert[m.mesh_vertadr[mid]:m.mesh_vertadr[mid] + m.mesh_vertnum[mid]]
        extents.add(tuple(np.round(v.max(0) - v.min(0), 3)))
    assert len(extents) == len(cars)
    rng = np.random.default_rng(4)
    assert {draw_body(rng).kind for _ in range(200)} == set(BODIES)
    body = CarBody("van", (1.05, 1.0, 0.97))
    from scenes.urban_actors import parts_mesh
    v = np.asarray(parts_mesh("car", body.parts(), body.wheels())[0]).reshape(-1, 3)
    assert abs(v.max(0)[0] - body.half_xy()[0]) < 1e-9 and abs(v.max(0)[2] - body.height()) < 1e-9
    assert body.half_xy()[1] <= v.max(0)[1] <= body.half_xy()[1] + 0.02 + 1e-9   # tyres 2 cm proud, as the traffic's
    assert abs(v.min(0)[2]) < 1e-9
    for kind in BODIES:                       # a traffic car's body fits the footprint its clearance checks use
        fit = CarBody(kind, (1.06, 1.04, 1.0)).fitted((2.2, 0.9))
        assert fit.half_xy()[0] <= 2.2 + 1e-9 and fit.half_xy()[1] <= 0.9 + 1e-9


def test_buses_are_each_a_bus_of_their_own(built):
    """Every bus has its own mesh (decks, length, width, height) and atlas (a tile of a sheet of its own), inside
    the clearance footprint; both deck counts appear (seed 0)."""
    import mujoco
    from scenes.actor_sheets import PER_SHEET
    from scenes.urban_actors import BUS_PARTS
    sc, spec, m = built
    role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    ids = {a.actor_id for a in sc.actors if a.kind == "bus"}
    assert len(ids) > 50
    geoms = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"dyn/urban/actor_{k}/body") for k in sorted(ids)]
    meshes = [int(m.geom_dataid[g]) for g in geoms]
    texs = [int(m.mat_texid[m.geom_matid[g], role]) for g in geoms]
    tiles = []                                 # (sheet texture, atlas tile the mesh maps into)
    for mid, tex in zip(meshes, texs):
        tc = m.mesh_texcoord[m.mesh_texcoordadr[mid]:m.mesh_texcoordadr[mid] + m.mesh_texcoordnum[mid]]
        lo, hi = np.floor(tc.min(0) * PER_SHEET["bus"]), np.floor(tc.max(0) * PER_SHEET["bus"])
        assert np.all(lo == hi)                # every texture coordinate inside one atlas of the sheet
        tiles.append((tex, *lo))
    assert len(set(meshes)) == len(geoms) and len(set(tiles)) == len(geoms)
    half_xy = np.array(BUS_PARTS[0][1][:2])
    heights = []
    spec_mesh = {me.name: me for me in spec.meshes}
    for k in sorted(ids):                      # vertices in the actor frame (the compiled mesh is turned)
        v = np.asarray(spec_mesh[f"mesh/urban/actor_{k}"].uservert).reshape(-1, 3)
        assert np.all(np.abs(v[:, 0]) <= half_xy[0] + 1e-9) and np.all(np.abs(v[:, 1]) <= half_xy[1] + 0.05 + 1e-9)
        assert abs(v[:, 2].min()) < 1e-9                 # on the ground; tyres 5 cm proud of the side
        heights.append(v[:, 2].max())
    assert min(heights) < 3.9 < max(heights)                  # single- and double-deckers


@pytest.mark.parametrize("seed,density", [(0, 1.0), (5, 0.3)])
def test_batched_actor_states_are_the_per_actor_poses_bit_for_bit(seed, density):
    """scene.actor_states (all actors in one pass, scenes.urban_actor_poses) against each Actor.poses, byte for
    byte, at times before the start, at the time origin and over 20 s; every motion law occurs."""
    from scenes.urban_actor_poses import ActorPoser
    from scenes.urban_actors import T_REF_NS
    sc = urban(seed, density)
    laws = {law for _, law, *_ in ActorPoser(sc.actors, T_REF_NS).groups}
    assert laws == {"line", "shuttle", "from rest"} and any(not a.moving for a in sc.actors) == (density < 1)
    for t_ns in [0, T_REF_NS, T_REF_NS + 1, *np.linspace(T_REF_NS, T_REF_NS + 20e9, 23).astype(np.int64)]:
        batched = sc.actor_states(int(t_ns))
        assert list(batched) == [a.body_name for a in sc.actors]
        for a in sc.actors:
            assert batched[a.body_name].tobytes() == a.poses([int(t_ns)])[0].tobytes()
