"""The lunar scene: terrain size, crater size-frequency statistics, the 17-site route, the exactness
of ground_height against the rendered surface, seeded reproducibility."""
import numpy as np
import pytest

from scenes import lunar, terrain
from scenes.base import SceneConfig
from scenes.registry import make_scene
from sim.rng import scene_streams


@pytest.fixture(scope="module")
def scene():
    return make_scene(SceneConfig(name="lunar", seed=3), scene_streams(3))


def test_terrain_covers_150_m_square(scene):
    xmin, xmax, ymin, ymax = scene.extent_xy()
    assert xmax - xmin >= 150 and ymax - ymin >= 150
    H, W = scene.z.shape
    assert (W - 1) * lunar.RES_M == pytest.approx(xmax - xmin) and (H - 1) * lunar.RES_M == pytest.approx(ymax - ymin)
    assert np.all(np.abs(scene.sites_xy) < 60)                     # the route stays well inside


def test_crater_sfd_slope_matches_the_set_exponent(scene):
    """MLE exponent of the drawn radii; its standard error is (slope - 1) / sqrt(n) = 0.08 for 600
    craters, so 0.25 is a 3-sigma tolerance."""
    r = np.array([c.radius for c in scene.craters_drawn])
    assert r.min() >= lunar.CRATER_R_M[0] and r.max() <= lunar.CRATER_R_M[1]
    assert terrain.power_law_slope(r, *lunar.CRATER_R_M) == pytest.approx(lunar.CRATER_SLOPE, abs=0.25)
    # a different exponent is told apart
    rng = np.random.default_rng(0)
    r2 = [c.radius for c in terrain.random_craters(rng, (0, 1, 0, 1), 600, *lunar.CRATER_R_M, slope=2.0)]
    assert terrain.power_law_slope(r2, *lunar.CRATER_R_M) == pytest.approx(2.0, abs=0.25)


def test_craters_have_rims_and_ejecta():
    c = terrain.Crater(0.0, 0.0, 4.0, 0.15, 0.04)
    prof = terrain.crater_profile(np.array([0.0, 4.0, 8.0]), c)
    assert prof[0] == pytest.approx(-0.15 * 8) and prof[1] == pytest.approx(0.04 * 8)
    assert prof[2] == pytest.approx(0.04 * 8 / 8)                 # ejecta blanket decays as (R/r)^3


def test_route_has_17_sites_about_115_m_at_most_10_m_apart(scene):
    legs = np.linalg.norm(np.diff(scene.sites_xy, axis=0), axis=1)
    assert len(scene.sites_xy) == 17 and len(scene.gcp_sites) == 17
    assert legs.max() <= 10.0 and legs.sum() == pytest.approx(114.8, abs=2.0)
    heading = np.degrees(np.arctan2(*np.diff(scene.sites_xy, axis=0).T[::-1]))
    assert np.ptp(np.unwrap(np.radians(heading))) > np.pi          # it turns, more than half a loop


def test_ground_height_is_the_mesh_at_the_grid_and_between():
    z = np.random.default_rng(1).random((5, 7))
    ext = (0.0, 3.0, 0.0, 2.0)
    ii, jj = np.meshgrid(range(5), range(7), indexing="ij")
    assert np.allclose(terrain.mesh_height(z, ext, 0.5, jj * 0.5, ii * 0.5), z)
    # the centroid of a triangle is the mean of its three vertices
    tri = terrain.grid_triangles(5, 7)[[0, 30]]
    zf, xf, yf = z.ravel(), (jj * 0.5).ravel(), (ii * 0.5).ravel()
    for t in tri:
        assert terrain.mesh_height(z, ext, 0.5, xf[t].mean(), yf[t].mean()) == pytest.approx(zf[t].mean())


def test_seeded_reproducibility():
    a = make_scene(SceneConfig(name="lunar", seed=5), scene_streams(5))
    b = make_scene(SceneConfig(name="lunar", seed=5), scene_streams(5))
    c = make_scene(SceneConfig(name="lunar", seed=6), scene_streams(6))
    assert np.array_equal(a.z, b.z) and not np.allclose(a.z, c.z)
    assert lunar.regolith_texture(np.random.default_rng(2), 64, 0.8).tobytes() == \
        lunar.regolith_texture(np.random.default_rng(2), 64, 0.8).tobytes()


def test_shadows_default_on_and_sun_knobs(scene):
    assert scene.config.shadows is True
    off = make_scene(SceneConfig(name="lunar", seed=3, shadows=False), scene_streams(3))
    assert off.config.shadows is False
    s = make_scene(SceneConfig(name="lunar", seed=3, sun_elevation_deg=30, sun_azimuth_deg=90), scene_streams(3))
    assert s.sun_direction() == pytest.approx([0.0, np.cos(np.radians(30)), 0.5], abs=1e-12)


def test_rendered_depth_matches_ground_height(scene):
    """Back-project the rendered depth at three pixels (centre included) with the exact camera pose;
    the point must lie on ground_height to float32 depth precision (1e-4 m at ~5 m)."""
    from rigs.geometry import make_T, rot_z
    from rigs.presets import get_rig
    from sim.render import StereoRenderer
    from sim.world import build_world
    rig = get_rig("yutu-navcam")
    xy = scene.sites_xy[4]
    T_w_b = make_T(rot_z(0.3), np.r_[xy, scene.ground_height(*xy)])
    with StereoRenderer(build_world(scene, rig, vehicle="rover"), rig, depth=True) as r:
        d = r.render(T_w_b).depth[0]
    cam = rig.cameras[0]
    T_w_c = T_w_b @ cam.T_b_c_array
    for u, v in ((512, 512), (150, 900), (880, 300)):
        p_c = np.linalg.inv(cam.K) @ np.array([u, v, 1.0]) * d[v, u]
        p_w = T_w_c[:3, :3] @ p_c + T_w_c[:3, 3]
        assert p_w[2] == pytest.approx(float(scene.ground_height(p_w[0], p_w[1])), abs=1e-3)


def test_chunk_texture_transform_is_a_similarity_of_its_own_per_chunk():
    """Each chunk's texture mapping is a rotation (+ mirror) and scale about its first vertex, tile 3.4-4.6 m;
    64 chunks draw 64 different ones."""
    from scenes.lunar import TILE_STRETCH, chunk_uv_transform
    uv = np.random.default_rng(0).random((50, 2)) * 5
    rng = np.random.default_rng(1)
    seen = set()
    for _ in range(64):
        out = chunk_uv_transform(uv, rng)
        A, *_ = np.linalg.lstsq(np.c_[uv - uv[0], np.ones(len(uv))], out - out[0], rcond=None)
        L = A[:2].T
        k = np.sqrt(abs(np.linalg.det(L)))
        np.testing.assert_allclose(L @ L.T, k * k * np.eye(2), atol=1e-9)       # similarity, no shear
        assert 1 / TILE_STRETCH[1] - 1e-12 <= k <= 1 / TILE_STRETCH[0] + 1e-12
        seen.add(tuple(np.round(L.ravel(), 6)))
    assert len(seen) == 64
