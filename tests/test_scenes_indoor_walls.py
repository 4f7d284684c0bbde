"""Indoor walls: every wall side has its own texture drawn at its full extent (nothing repeats within a surface,
no two sides alike), seeded (same seed, same bytes), and the indoor scene passes the place-recognition check."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from scenes.errors import SceneError  # noqa: E402
from scenes.indoor_walls import PX_PER_M, wall_texture  # noqa: E402
from sim.rng import scene_streams  # noqa: E402


def _best_elsewhere(img, y, x, size=48, exclude=8):
    """Highest normalised cross-correlation of the ``size`` patch at (y, x) of grey ``img`` anywhere but within
    ``exclude`` px of its own place (1.0 at a repeat of the patch)."""
    import cv2
    g = img.mean(axis=2).astype(np.float32)
    r = cv2.matchTemplate(g, g[y:y + size, x:x + size], cv2.TM_CCOEFF_NORMED)
    r[max(0, y - exclude):y + exclude + 1, max(0, x - exclude):x + exclude + 1] = -1.0
    return float(r.max())


def test_wall_texture_seeded_full_extent_and_no_repeat():
    img = wall_texture(scene_streams(0)("texture/wall/a/left"), 9.0, 3.0, "plaster", 1.0, doors=((4.0, 5.2),))
    assert img.dtype == np.uint8 and img.shape == (256, round(9.0 * PX_PER_M), 3)
    again = wall_texture(scene_streams(0)("texture/wall/a/left"), 9.0, 3.0, "plaster", 1.0, doors=((4.0, 5.2),))
    assert img.tobytes() == again.tobytes()
    other = wall_texture(scene_streams(0)("texture/wall/a/right"), 9.0, 3.0, "plaster", 1.0, doors=((4.0, 5.2),))
    assert np.abs(img.astype(int) - other.astype(int)).mean() > 3.0
    # nothing recurs within the surface: a 0.56 m patch (paint, cracks, stains) has no copy elsewhere on the wall,
    # where the 3 m tile of the scenes' square textures repeats it exactly (correlation 1 one tile further on)
    for y, x in ((40, 100), (120, 300), (60, 600)):
        assert _best_elsewhere(img, y, x) < 0.7
    tiled = np.tile(img[:, :256], (1, 3, 1))
    assert _best_elsewhere(tiled, 40, 100) > 0.99
    # skirting along the floor (the bottom rows), the same along the wall
    bottom = img[-4:].reshape(-1, 3).astype(float)
    assert bottom.std(axis=0).max() < 12.0


def test_wall_texture_richness_and_white_style():
    rng = scene_streams(3)
    flat = wall_texture(rng("texture/wall/b/left"), 4.0, 3.0, "plaster", 0.0)
    assert np.ptp(flat.reshape(-1, 3), axis=0).max() <= 1                    # richness 0: one colour
    white = wall_texture(rng("texture/wall/c/left"), 4.0, 3.0, "white", 1.0).astype(float).mean(axis=2)[:200]
    plaster = wall_texture(rng("texture/wall/c/left"), 4.0, 3.0, "plaster", 1.0).astype(float).mean(axis=2)[:200]

    def busy(g):                                          # share of texels 10 grey levels off the wall's median
        return float((np.abs(g - np.median(g)) > 10).mean())

    assert white.mean() > 215 and busy(white) < 0.05 < 0.15 < busy(plaster)   # near-white, texture-poor
    with pytest.raises(SceneError, match="style"):
        wall_texture(rng("texture/wall/x/left"), 4.0, 3.0, "brick", 1.0)
    with pytest.raises(SceneError, match="richness"):
        wall_texture(rng("texture/wall/x/left"), 4.0, 3.0, "plaster", 1.5)


def _wall_textures(seed):
    """{texture name: bytes} of the indoor scene's wall sides."""
    import mujoco
    from scenes import SceneConfig, make_scene
    spec = mujoco.MjSpec()
    make_scene(SceneConfig(name="indoor"), scene_streams(seed)).add_to_spec(spec)
    return {t.name: bytes(t.data) for t in spec.textures if t.name.startswith("tex/wall/")}


def test_indoor_wall_sides_each_their_own_texture_same_seed_same_bytes():
    a = _wall_textures(0)
    # 9 walls, the 4 inner ones seen from both sides, the 5 outer ones from inside only
    assert len(a) == 13
    assert len(set(a.values())) == len(a)
    assert a == _wall_textures(0)
    b = _wall_textures(1)
    assert set(b) == set(a) and all(a[k] != b[k] for k in a)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 2, 4, 5])
def test_indoor_places_no_look_alikes(seed):
    """Indoor, a place every 2 m: no distinct pair of places is verified at or above the weakest revisit, none
    reaches a loop closure's 40, and every revisit is verified (above the minimal sample). Before the scene's
    fixtures and prints (dataset 0.6.0) seeds 2 and 5 failed the last: their revisit of place 8 (the partition and
    the white wall) kept 4 places, and seed 5 failed the check (a distinct pair at 5, glyph-block rows of a poster
    onto a shelf); seed 4: two copies of one poster pattern once matched with 13 places. Measured at 0.7.0:
    weakest revisits 11 / 25 / 7 / 13, distinct pairs at most 5 / 4 / 4 / 5."""
    from sim.app.validation.place_recognition import LOOP_ACCEPT_INLIERS, PlaceConfig, check_places, render_views
    from sim.scenarios import get_scenario
    place = PlaceConfig(spacing_m=2.0)
    places, revisits = render_views(get_scenario("indoor", seed=seed), place, progress=False)
    res, _ = check_places(places, revisits, "indoor", place, progress=False)
    assert len(places) == 10 and len(res.distinct) > 100
    assert res.passed and max(res.distinct) < LOOP_ACCEPT_INLIERS, res.table()
    assert res.revisit.min() > place.minimal_sample and np.median(res.revisit) > 4 * place.minimal_sample, res.table()


@pytest.mark.slow
def test_indoor_posters_desks_and_items_each_a_pattern_of_their_own():
    """Every poster, desk top and desk item wears a texture of its own (not a tint of a shared pattern, which ORB
    on grey images sees as one: two copies of one poster were a look-alike place on seed 4), different in grey,
    the same bytes for the same seed."""
    import mujoco
    from scenes import SceneConfig, make_scene

    def own(seed):
        spec = mujoco.MjSpec()
        make_scene(SceneConfig(name="indoor"), scene_streams(seed)).add_to_spec(spec)
        tex = {t.name: t for t in spec.textures}
        out = {}
        for g in spec.geoms:
            part = g.name.split("/", 1)[-1]
            if part.startswith("decor/poster") or part.endswith(("/top", "/item")):
                t = tex[f"tex/{g.material.split('/', 1)[1]}"]
                out[part] = np.frombuffer(bytes(t.data), np.uint8).reshape(t.height, t.width, 3)
        return out

    a = own(4)
    assert sum(k.startswith("decor/poster") for k in a) == 12 and sum(k.endswith("/top") for k in a) == 7
    grey = {k: v.mean(axis=2) for k, v in a.items()}
    keys = sorted(grey)
    for i, k in enumerate(keys):
        for j in keys[i + 1:]:
            assert np.abs(grey[k] - grey[j]).mean() > 3.0, (k, j)
    again = own(4)
    assert all(a[k].tobytes() == again[k].tobytes() for k in a)
