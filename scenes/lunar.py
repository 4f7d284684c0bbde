"""Seed 001's lunar test field: a seeded regolith terrain and a Yutu-like 17-site traverse.

World frame: x east, y north, z up. The terrain covers :data:`EXTENT` (160 x 160 m) as a height grid
at :data:`RES_M` (0.25 m): craters with a power-law size-frequency distribution (differential
exponent :data:`CRATER_SLOPE`, cumulative N(>r) ~ r^-2 as for small lunar craters), parabolic bowls,
raised rims and an ejecta blanket (:mod:`scenes.terrain`), blocks thrown out around the larger
craters, scattered rocks and a fractal roughness of :data:`ROUGHNESS_M`. Craters wider than 0.8 m
and rocks are kept out of a :data:`CORRIDOR_M` corridor around the route (the rover's planners
avoid them). The grid is rendered as a triangle mesh whose triangles :func:`scenes.terrain.mesh_height`
interpolates, so :meth:`LunarScene.ground_height` is the rendered surface exactly.

The surface carries a grey regolith texture (grains and pits down to ~4 mm: a 1024-texel tile per
:data:`TEX_TILE_M` = 4 m) in :data:`N_TEX_VARIANTS` seeded variants, one chosen per 20 m chunk with
a random offset, its own angle, handedness and tile size (3.4-4.6 m, :func:`chunk_uv_transform`), so no two
chunks show the same pattern at the same orientation and scale; craters and rocks are each drawn on
their own (sizes, depths, places), no two alike. Within a chunk its variant still repeats every tile.
One sun (``sun_elevation_deg``, ``sun_azimuth_deg``), no ambient light, no headlight, a black sky; shadows on unless
``shadows: false``.

Route: 17 sites (S00..S16) joined by 16 legs of 5-9.5 m, 114.5 m of straight legs, first heading
south, then turning left through a loop and away to the south-west, as Yutu's traverse of seed 001
Fig. 5 (114.8 m over 17 sites). The vehicle drives a smooth curve through the sites.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from scenes.base import GcpSite, Route, Scene
from scenes.routes import distance_to_polyline
from scenes import terrain
from scenes.texture_store import TextureStore

EXTENT = (-80.0, 80.0, -80.0, 80.0)
RES_M = 0.25
CHUNK_CELLS = 80                   # 20 m mesh chunks (one texture variant each)
CRATER_SLOPE = 3.0
N_CRATERS = 600
CRATER_R_M = (0.4, 15.0)
N_ROCKS = 1500
ROUGHNESS_M = 0.04
CORRIDOR_M = 1.5
TEX_TILE_M = 4.0
TEX_SIZE = 1024
N_TEX_VARIANTS = 4
TILE_STRETCH = (0.85, 1.15)        # a chunk's tile size, as a multiple of TEX_TILE_M
LEG_M = (8.5, 9.0, 7.5, 6.0, 8.0, 9.5, 5.5, 7.0, 8.0, 6.5, 7.5, 9.0, 6.0, 5.0, 6.5, 5.0)
LEG_HEADING_DEG = (-90, -90, -60, -20, 10, 40, 75, 110, 140, 170, 200, 220, 210, 235, 250, 260)
CRUISE_MPS = 0.2
ACCEL_MPS2 = 0.1


def site_positions() -> np.ndarray:
    """(17, 2) site x, y (m): the legs from the first site, the whole centred on the origin."""
    h = np.radians(LEG_HEADING_DEG)
    steps = np.asarray(LEG_M)[:, None] * np.stack([np.cos(h), np.sin(h)], axis=1)
    xy = np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])
    return xy - (xy.min(axis=0) + xy.max(axis=0)) / 2


def regolith_texture(rng: np.random.Generator, size: int, richness: float) -> np.ndarray:
    """(size, size, 3) uint8 tileable grey regolith: fractal albedo, fine grains (blurred white
    noise) and small dark pits with bright rims; ``richness`` scales the contrast about the mean."""
    from scipy.ndimage import gaussian_filter
    from scenes.textures import fbm
    img = 0.10 * fbm(rng, size, 4, 6)
    for sigma, amp in ((0.8, 0.10), (2.5, 0.07)):
        g = gaussian_filter(rng.standard_normal((size, size)), sigma, mode="wrap")
        img += amp * g / g.std()
    n_pits = size * size // 900
    yy, xx = np.mgrid[-6:7, -6:7]
    for cy, cx, r in zip(rng.integers(0, size, n_pits), rng.integers(0, size, n_pits), rng.uniform(1.5, 5, n_pits)):
        d = np.hypot(yy, xx) / r
        stamp = np.where(d < 1, -0.12 * (1 - d ** 2), np.where(d < 1.4, 0.06 * (1.4 - d) / 0.4, 0.0))
        img[np.ix_((cy + yy[:, 0]) % size, (cx + xx[0]) % size)] += stamp
    grey = np.clip(0.42 + float(richness) * img, 0, 1)
    return np.repeat(np.round(grey * 255).astype(np.uint8)[..., None], 3, axis=2)


def chunk_uv_transform(uv: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(N, 2) texture coordinates of one terrain chunk turned by its own angle (uniform in 0-360 deg),
    mirrored with probability 1/2 and scaled by its own tile size (:data:`TILE_STRETCH` x the tile), about
    the chunk's first vertex: no two chunks show a variant at the same orientation, handedness and scale."""
    a = rng.uniform(0.0, 2.0 * np.pi)
    mirror = -1.0 if rng.random() < 0.5 else 1.0
    k = 1.0 / rng.uniform(*TILE_STRETCH)
    R = k * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) @ np.diag([mirror, 1.0])
    return (uv - uv[0]) @ R.T + uv[0]


class LunarScene(Scene):
    """Regolith terrain with craters and rocks, one low sun, and the 17-site traverse route."""

    name = "lunar"

    def __init__(self, config, streams):
        if config.shadows is None:
            config = dataclasses.replace(config, shadows=True)
        super().__init__(config)
        self.streams = streams
        self.sites_xy = site_positions()
        self._build_terrain()

    def _build_terrain(self) -> None:
        ext, route = EXTENT, self.sites_xy
        self.craters_drawn = terrain.random_craters(self.streams("lunar/craters"), ext, N_CRATERS, *CRATER_R_M,
                                                    slope=CRATER_SLOPE, depth_ratio=(0.08, 0.18))
        near = distance_to_polyline([(c.x, c.y) for c in self.craters_drawn], route)
        self.craters = tuple(c for c, d in zip(self.craters_drawn, near)
                             if c.radius <= 0.8 or d > c.radius * 1.6 + CORRIDOR_M)
        rocks = list(terrain.random_rocks(self.streams("lunar/rocks"), ext, N_ROCKS, 0.25, 0.6))
        rng = self.streams("lunar/ejecta")
        for c in self.craters:
            if c.radius > 2.5:
                k = int(2 * c.radius)
                ang, dist = rng.uniform(0, 2 * np.pi, k), c.radius * rng.uniform(1.1, 2.0, k)
                a = np.minimum(0.8, c.radius * rng.uniform(0.04, 0.1, k))
                rocks += [(c.x + d * np.cos(t), c.y + d * np.sin(t), r, r * 0.5) for t, d, r in zip(ang, dist, a)]
        keep = distance_to_polyline([(r[0], r[1]) for r in rocks], route) > CORRIDOR_M + np.array([r[2] for r in rocks])
        self.rocks = tuple(r for r, k in zip(rocks, keep) if k)
        self.z = terrain.heightfield(ext, RES_M, self.craters, self.rocks, ROUGHNESS_M, self.streams("lunar/roughness"))

    # ------------------------------------------------------------------ Scene interface
    @property
    def route(self) -> Route:
        return Route(tuple(map(tuple, self.sites_xy.round(4))), closed=False,
                     cruise_speed_mps=CRUISE_MPS, accel_mps2=ACCEL_MPS2)

    @property
    def gcp_sites(self) -> tuple:
        return tuple(GcpSite(f"S{k:02d}", float(x), float(y)) for k, (x, y) in enumerate(self.sites_xy.round(4)))

    def ground_height(self, x, y) -> np.ndarray:
        return terrain.mesh_height(self.z, EXTENT, RES_M, x, y)

    def extent_xy(self) -> tuple:
        return EXTENT

    def footprints(self) -> list:
        """Top-down outlines for maps: craters (rim circles, wider than 1.6 m) and rocks."""
        from scenes.builder import Footprint
        out = [Footprint(f"crater{k}", "crater", (c.x, c.y), radius=c.radius)
               for k, c in enumerate(self.craters) if c.radius > 0.8]
        return out + [Footprint(f"rock{k}", "rock", (r[0], r[1]), radius=r[2]) for k, r in enumerate(self.rocks)]

    def sun_direction(self) -> np.ndarray:
        """Unit vector from the ground towards the sun (world)."""
        el, az = np.radians(self.config.sun_elevation_deg), np.radians(self.config.sun_azimuth_deg)
        return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])

    def add_to_spec(self, spec, textures=None) -> None:
        import mujoco
        self._add_materials(spec, textures if textures is not None else TextureStore(None))
        self._add_mesh_chunks(spec)
        vis = spec.visual
        vis.headlight.active = 0
        vis.headlight.ambient = [0.0] * 3
        vis.headlight.diffuse = [0.0] * 3
        vis.headlight.specular = [0.0] * 3
        to_sun = self.sun_direction()
        centre = np.r_[self.sites_xy.mean(axis=0), 0.0]
        # exposure: the camera gain that puts flat ground at the brightness of a 45 deg sun
        d = float(self.config.lighting) * min(4.0, np.sin(np.pi / 4) / max(to_sun[2], 1e-3))
        spec.worldbody.add_light(name="static/sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                                 pos=(centre + 60 * to_sun).tolist(), dir=(-to_sun).tolist(),
                                 diffuse=[d] * 3, ambient=[0.0] * 3, specular=[0.0] * 3,
                                 castshadow=bool(self.config.shadows))

    def _add_materials(self, spec, textures: TextureStore) -> None:
        import mujoco
        richness = self.config.texture_richness
        for v in range(N_TEX_VARIANTS):
            key = f"texture/regolith/{v}"
            img = textures.get((self.streams(key),), ("regolith", TEX_SIZE, richness),
                               lambda: regolith_texture(self.streams(key), TEX_SIZE, richness))
            tex = spec.add_texture(name=f"tex/regolith/{v}", type=mujoco.mjtTexture.mjTEXTURE_2D,
                                   width=TEX_SIZE, height=TEX_SIZE, nchannel=3)
            tex.data = img.tobytes()
            mat = spec.add_material(name=f"mat/regolith/{v}", specular=0.0, shininess=0.0, reflectance=0.0)
            tx = list(mat.textures)
            tx[mujoco.mjtTextureRole.mjTEXROLE_RGB] = f"tex/regolith/{v}"
            mat.textures = tx

    def _add_mesh_chunks(self, spec) -> None:
        """The height grid as triangle meshes of CHUNK_CELLS^2 cells (sharing border vertices)."""
        import mujoco
        x, y = terrain.grid_xy(EXTENT, RES_M)
        rng = self.streams("lunar/chunks")
        H, W = self.z.shape
        for ci, i0 in enumerate(range(0, H - 1, CHUNK_CELLS)):
            for cj, j0 in enumerate(range(0, W - 1, CHUNK_CELLS)):
                i1, j1 = min(i0 + CHUNK_CELLS, H - 1), min(j0 + CHUNK_CELLS, W - 1)
                X, Y = np.meshgrid(x[j0:j1 + 1], y[i0:i1 + 1])
                Z = self.z[i0:i1 + 1, j0:j1 + 1]
                off = rng.random(2)
                uv = np.stack([X.ravel() / TEX_TILE_M + off[0], -Y.ravel() / TEX_TILE_M + off[1]], axis=1)
                variant = int(rng.integers(N_TEX_VARIANTS))
                uv = chunk_uv_transform(uv, rng)
                m = spec.add_mesh(name=f"mesh/terrain_{ci}_{cj}")
                m.uservert = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1).ravel().tolist()
                m.usertexcoord = uv.ravel().tolist()
                m.userface = terrain.grid_triangles(*Z.shape).ravel().tolist()
                m.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
                spec.worldbody.add_geom(name=f"static/terrain_{ci}_{cj}", type=mujoco.mjtGeom.mjGEOM_MESH,
                                        meshname=m.name, material=f"mat/regolith/{variant}",
                                        contype=0, conaffinity=0, group=0)
