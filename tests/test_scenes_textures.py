"""Procedural textures: determinism, richness semantics, errors; terrain crater placement."""
import numpy as np
import pytest

from scenes.errors import SceneError
from scenes.terrain import Crater, crater_profile, grid_xy, heightfield, random_craters
from scenes.textures import make_texture, texture_kinds
from sim.rng import scene_streams


def _tex(kind, seed, richness, size=256, variant=0):
    """The texture the simulator makes: scene stream of ``seed``, key ``texture/<kind>/<variant>``."""
    return make_texture(kind, scene_streams(seed)(f"texture/{kind}/{variant}"), richness, size)


@pytest.mark.parametrize("kind", texture_kinds())
def test_same_seed_same_bytes_other_seed_differs(kind):
    a = _tex(kind, 7, 0.8, 64)
    assert a.shape == (64, 64, 3) and a.dtype == np.uint8
    assert a.tobytes() == _tex(kind, 7, 0.8, 64).tobytes()
    assert a.tobytes() != _tex(kind, 8, 0.8, 64).tobytes()
    assert a.tobytes() != _tex(kind, 7, 0.8, 64, variant=1).tobytes()


@pytest.mark.parametrize("kind", texture_kinds())
def test_richness_zero_is_flat_and_one_is_textured(kind):
    flat = _tex(kind, 3, 0.0, 128)
    assert np.all(flat == flat[0, 0])                     # one colour, no texture at all
    rich = _tex(kind, 3, 1.0, 128).astype(float)
    half = _tex(kind, 3, 0.5, 128).astype(float)
    # contrast scales with richness: half richness gives half the std (within rounding/clipping)
    s1, s05 = rich.std(axis=(0, 1)).mean(), half.std(axis=(0, 1)).mean()
    assert s1 > 8.0
    assert s05 == pytest.approx(0.5 * s1, rel=0.1)


def test_rich_textures_have_many_corners():
    import cv2
    for kind in ("pavement", "brick", "facade", "poster", "bark", "foliage", "carpet", "asphalt"):
        g = cv2.cvtColor(_tex(kind, 0, 1.0, 256), cv2.COLOR_RGB2GRAY)
        c = cv2.goodFeaturesToTrack(g, 1000, 0.01, 5)
        assert c is not None and len(c) >= 60, kind


def test_bad_texture_arguments_raise_one_line():
    rng = np.random.default_rng(0)
    for args in (("nope", rng, 0.5), ("brick", rng, 1.5), ("brick", 0, 0.5), ("brick", rng, 0.5, 100)):
        with pytest.raises(SceneError) as e:
            make_texture(*args)
        assert "\n" not in str(e.value)
    with pytest.raises(SceneError, match="valid: asphalt"):
        make_texture("nope", rng, 0.5)


def test_crater_profile_is_where_requested():
    res = 0.05
    extent = (-10, 10, -10, 10)
    craters = (Crater(3.0, -2.0, 2.0), Crater(-4.0, 5.0, 1.0))
    z = heightfield(extent, res, craters)
    x, y = grid_xy(extent, res)
    for c in craters:
        near = (np.abs(x[None, :] - c.x) < 1.5 * c.radius) & (np.abs(y[:, None] - c.y) < 1.5 * c.radius)
        i, j = np.unravel_index(np.argmin(np.where(near, z, np.inf)), z.shape)
        assert abs(x[j] - c.x) <= res and abs(y[i] - c.y) <= res   # floor at the centre, to one cell
        # depth = 0.2 * diameter; the other crater's ejecta adds < 1 mm here ((R/r)^3 tail)
        assert z[i, j] == pytest.approx(-0.4 * c.radius, abs=2e-3)
    r = np.linspace(0, 6, 601)
    prof = crater_profile(r, craters[0])
    assert r[np.argmax(prof)] == pytest.approx(2.0, abs=0.01)       # rim crest at the radius
    assert prof.max() == pytest.approx(0.04 * 4.0)


def test_random_craters_seeded():
    a = random_craters(np.random.default_rng(1), (0, 50, 0, 50), 20)
    b = random_craters(np.random.default_rng(1), (0, 50, 0, 50), 20)
    assert a == b and all(0.5 <= c.radius <= 8.0 for c in a)
