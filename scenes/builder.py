"""Small helpers that add textured static geometry to a ``mujoco.MjSpec`` and record 2-D footprints.

Boxes, cylinders, ellipsoids and path strips are built as meshes with explicit texture coordinates
in metres divided by the material's tile size (``tile_m`` = world size of one texture repeat), so a
texel has a known world size on every face (MuJoCo's own box/cylinder texture mapping depends on the
geom size).  Planes (ground) use ``texuniform`` with ``texrepeat = 1 / tile_m`` per metre.

Every geom is named ``static/<part>``; ``dyn/`` is reserved for moving objects.  Static geoms do not
collide (contype = conaffinity = 0): the vehicle is driven kinematically.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from scenes.errors import SceneError
from scenes.texture_store import TextureStore
from scenes.textures import make_texture, weather

STATIC_PREFIX = "static/"
GROUND_CATEGORIES = ("ground", "path")     # no stickers on what one drives and walks on
UNIQUE_AREA_M2 = 8.0          # surfaces at least this large get their own pattern (SceneBuilder.instance_material)
DYNAMIC_PREFIX = "dyn/"


@dataclass(frozen=True)
class Footprint:
    """Top-down outline of one static geom: a rectangle (centre, half sizes, yaw) or a circle."""

    name: str
    category: str
    center_xy: tuple
    half_xy: tuple = (0.0, 0.0)   # rect half sizes in its own frame (m)
    yaw: float = 0.0              # rad, rect x axis from world x
    radius: float = 0.0           # circle radius (m); 0 for rects
    z_range: tuple = (0.0, 0.0)

    def corners_xy(self) -> np.ndarray:
        """(4, 2) rectangle corners in world x-y (counter-clockwise)."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        hx, hy = self.half_xy
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.center_xy)


class _Mesh:
    """Accumulates un-shared vertices (flat shading), texture coordinates and outward triangles."""

    def __init__(self):
        self.v, self.uv, self.f = [], [], []

    def tri(self, p, uv, n_out):
        p = [np.asarray(q, float) for q in p]
        (a0, a1, a2), (b0, b1, b2) = (p[1] - p[0]).tolist(), (p[2] - p[0]).tolist()   # np.cross's bits, faster:
        if np.dot([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], n_out) < 0:
            p, uv = [p[0], p[2], p[1]], [uv[0], uv[2], uv[1]]
        self.f.append([len(self.v), len(self.v) + 1, len(self.v) + 2])
        self.v += p
        self.uv += list(uv)

    def quad(self, p, uv, n_out):
        self.tri(p[:3], uv[:3], n_out)
        self.tri([p[0], p[2], p[3]], [uv[0], uv[2], uv[3]], n_out)


def _yaw_R(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


class SceneBuilder:
    """Adds named, textured static geoms, materials and lights to one ``MjSpec``.

    ``streams`` is the scene's random-stream factory (key -> ``np.random.Generator``, the simulator's
    ``scene`` stream); texture ``(kind, variant)`` draws from key ``texture/<kind>/<variant>``, is made
    once and shared (through ``textures``, a :class:`scenes.texture_store.TextureStore`). ``richness`` comes
    from the ``SceneConfig``. ``footprints`` collects the top-down outline of every geom."""

    def __init__(self, spec, streams, richness: float, lighting: float = 1.0,
                 shadows: bool = False, tex_size: int = 256, textures: TextureStore | None = None):
        self.spec, self.streams, self.richness = spec, streams, float(richness)
        self.textures = textures if textures is not None else TextureStore(None)
        self.lighting, self.shadows, self.tex_size = float(lighting), bool(shadows), int(tex_size)
        self.footprints: list[Footprint] = []
        self._names: set[str] = set()
        self._textures: dict[tuple, str] = {}
        self._materials: set[str] = set()
        self._kinds: dict[str, tuple] = {}      # shared material -> (kind, variant, size, plane_tile_m, specular)
        self.texture_bytes = 0
        self.instance_textures = 0

    # ------------------------------------------------------------------ assets
    def _texture_rng(self, kind: str, variant: int) -> np.random.Generator:
        return self.streams(f"texture/{kind}/{int(variant)}")

    def texture(self, kind: str, variant: int = 0, size: int | None = None) -> str:
        key = (kind, int(variant))
        if key not in self._textures:
            size = size or self.tex_size
            img = self.textures.get((self._texture_rng(kind, variant),), ("shared", kind, self.richness, size),
                                    lambda: make_texture(kind, self._texture_rng(kind, variant), self.richness, size))
            name = f"tex/{kind}/{variant}"
            tex = self.spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D,
                                        width=img.shape[1], height=img.shape[0], nchannel=3)
            tex.data = img.tobytes()
            self.texture_bytes += img.nbytes
            self._textures[key] = name
        return self._textures[key]

    def material(self, kind: str, variant: int = 0, size: int | None = None,
                 plane_tile_m: float | None = None, specular: float = 0.1) -> str:
        """Textured material of ``kind`` for the geoms of this builder; for planes pass ``plane_tile_m`` (world
        size of one repeat). The name stands for a family: each geom given it gets its own instance
        (:meth:`instance_material`), made when the geom is added."""
        name = f"mat/{kind}/{variant}" + (f"/plane{plane_tile_m:g}" if plane_tile_m else "")
        if name not in self._kinds:
            self._kinds[name] = (kind, int(variant), size or self.tex_size, plane_tile_m, specular)
        return name

    def instance_material(self, material: str, part: str, area_m2: float, decals: bool = True) -> str:
        """The material a geom ``part`` of surface ``area_m2`` actually gets for the shared ``material`` (made by
        :meth:`material`): every surface instance has its own seeded variation, so no two places look alike.

        * ``area_m2 >= UNIQUE_AREA_M2`` (facades, walls, crowns, ground, signs): its own pattern, drawn by the
          kind's generator from stream ``texture/<kind>/<part>`` at the material's size, then weathered
          (:func:`scenes.textures.weather`: colour, grime, stains and, unless ``decals`` is false (the ground),
          stickers; stream ``texture/weather/<part>``);
        * smaller parts (poles, benches, bins): the shared pattern under their own colour (material ``rgba``,
          stream ``texture/tint/<part>``), which costs no texture memory.

        Any other material (flat, texture-poor, images) is returned unchanged."""
        info = self._kinds.get(material)
        if info is None:
            return material
        kind, _, size, plane_tile_m, specular = info
        name = f"mat/{kind}/i/{part}"
        if area_m2 >= UNIQUE_AREA_M2:
            keys = (f"texture/{kind}/{part}", f"texture/weather/{part}")
            img = self.textures.get(
                tuple(self.streams(k) for k in keys), ("instance", kind, self.richness, size, bool(decals)),
                lambda: weather(make_texture(kind, self.streams(keys[0]), self.richness, size),
                                self.streams(keys[1]), stickers=decals))
            tex_name = f"tex/{kind}/i/{part}"
            tex = self.spec.add_texture(name=tex_name, type=mujoco.mjtTexture.mjTEXTURE_2D,
                                        width=img.shape[1], height=img.shape[0], nchannel=3)
            tex.data = img.tobytes()
            self.texture_bytes += img.nbytes
            self.instance_textures += 1
            mat = self.spec.add_material(name=name, specular=specular, shininess=0.1)
            tx = list(mat.textures)
            tx[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex_name
            mat.textures = tx
        else:
            rng = self.streams(f"texture/tint/{part}")
            tint = np.clip(rng.uniform(0.82, 1.0) * (1.0 + rng.normal(0.0, 0.05, 3)), 0.0, 1.0)
            mat = self.spec.add_material(name=name, specular=specular, shininess=0.1, rgba=[*map(float, tint), 1.0])
            tx = list(mat.textures)
            tx[mujoco.mjtTextureRole.mjTEXROLE_RGB] = self.texture(kind, info[1], size)
            mat.textures = tx
        if plane_tile_m:
            mat.texuniform = True
            mat.texrepeat = [1.0 / plane_tile_m, 1.0 / plane_tile_m]
        self._materials.add(name)
        return name

    def image_material(self, name: str, img: np.ndarray, specular: float = 0.1, shininess: float = 0.3) -> str:
        """Material ``mat/<name>`` textured with the ``(H, W, 3) uint8`` image ``img`` (e.g. an actor's atlas)."""
        mat_name, tex_name = f"mat/{name}", f"tex/{name}"
        if mat_name in self._materials:
            raise SceneError(f"scene material {mat_name!r} made twice")
        tex = self.spec.add_texture(name=tex_name, type=mujoco.mjtTexture.mjTEXTURE_2D,
                                    width=img.shape[1], height=img.shape[0], nchannel=3)
        tex.data = np.ascontiguousarray(img, np.uint8).tobytes()
        self.texture_bytes += img.nbytes
        mat = self.spec.add_material(name=mat_name, specular=specular, shininess=shininess)
        tx = list(mat.textures)
        tx[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex_name
        mat.textures = tx
        self._materials.add(mat_name)
        return mat_name

    def poor_material(self, name: str, kind: str = "plaster", contrast: float = 0.3, white: float = 232.0,
                      variant: int = 0) -> str:
        """Texture-poor near-white material: a ``kind`` texture at low ``contrast`` (independent of the
        scene's richness) shifted to a mean grey of ``white``. Models a real white wall: almost no
        corners, but not the perfectly blank surface no visual method could ever track."""
        name = f"mat/poor/{name}"
        if name not in self._materials:
            img = self.textures.get((self._texture_rng(kind, variant),), ("poor", kind, contrast, self.tex_size),
                                    lambda: make_texture(kind, self._texture_rng(kind, variant), contrast,
                                                         self.tex_size)).astype(float)
            img = np.clip(img - img.mean() + white, 0, 255).astype(np.uint8)
            tex_name = f"tex/poor/{name}"
            tex = self.spec.add_texture(name=tex_name, type=mujoco.mjtTexture.mjTEXTURE_2D,
                                        width=img.shape[1], height=img.shape[0], nchannel=3)
            tex.data = img.tobytes()
            self.texture_bytes += img.nbytes
            mat = self.spec.add_material(name=name, specular=0.05, shininess=0.1)
            tx = list(mat.textures)
            tx[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex_name
            mat.textures = tx
            self._materials.add(name)
        return name

    def flat_material(self, name: str, rgba, emission: float = 0.0) -> str:
        """Untextured material (e.g. the plain white walls that stay texture-poor at any richness)."""
        name = f"mat/flat/{name}"
        if name not in self._materials:
            self.spec.add_material(name=name, rgba=list(rgba), specular=0.05, emission=emission)
            self._materials.add(name)
        return name

    # ------------------------------------------------------------------ geoms
    def _geom_name(self, part: str) -> str:
        name = STATIC_PREFIX + part
        if name in self._names:
            raise SceneError(f"scene geom name {name!r} used twice")
        self._names.add(name)
        return name

    def _add_mesh_geom(self, part, mesh: _Mesh, pos, material, category, footprint):
        name = self._geom_name(part)
        v = np.asarray(mesh.v, float).reshape(-1, 3, 3)
        area = 0.5 * float(np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum())
        material = self.instance_material(material, part, area, decals=category not in GROUND_CATEGORIES)
        m = self.spec.add_mesh(name=f"mesh/{part}")
        m.uservert = np.asarray(mesh.v, float).ravel().tolist()
        m.usertexcoord = np.asarray(mesh.uv, float).ravel().tolist()
        m.userface = np.asarray(mesh.f, int).ravel().tolist()
        self.spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"mesh/{part}",
                                     pos=list(map(float, pos)), material=material,
                                     contype=0, conaffinity=0, group=0)
        self.footprints.append(footprint)
        return name

    def box(self, part, center, half, material, yaw=0.0, tile_m=1.0, category="object", uv_off=None) -> str:
        """Axis-aligned (then yawed) box, ``center`` (3,) world, ``half`` (3,) half sizes (m); ``tile_m``: world size
        of one texture repeat, or its (u, v) pair; ``uv_off`` (2,): texture offset (m), default from the centre."""
        half, center, (tu, tv) = np.asarray(half, float), np.asarray(center, float), np.broadcast_to(tile_m, 2)
        if np.any(half <= 0):
            raise SceneError(f"box {part!r}: half sizes must be positive, got {tuple(half)}")
        R = _yaw_R(yaw)
        off = np.array([center[0] + center[1], center[2]]) if uv_off is None else np.asarray(uv_off, float)
        mesh = _Mesh()
        for ax, (ua, va) in ((0, (1, 2)), (1, (0, 2)), (2, (0, 1))):
            for sgn in (1.0, -1.0):
                pts, uvs = [], []
                for cu, cv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    p = np.zeros(3)
                    p[ax], p[ua], p[va] = sgn * half[ax], cu * half[ua], cv * half[va]
                    pts.append(R @ p)
                    uvs.append(((p[ua] * (sgn if ax != 2 else 1) + off[0]) / tu, -(p[va] + off[1]) / tv))
                n = np.zeros(3)
                n[ax] = sgn
                mesh.quad(pts, uvs, R @ n)
        fp = Footprint(STATIC_PREFIX + part, category, tuple(center[:2]), tuple(half[:2]), float(yaw),
                       0.0, (center[2] - half[2], center[2] + half[2]))
        return self._add_mesh_geom(part, mesh, center, material, category, fp)

    def cylinder(self, part, center_xy, z0, z1, radius, material, tile_m=1.0, segments=16,
                 category="object") -> str:
        """Vertical faceted cylinder from ``z0`` to ``z1`` (m)."""
        if not (z1 > z0 and radius > 0):
            raise SceneError(f"cylinder {part!r}: need z1 > z0 and radius > 0, got {z0}, {z1}, {radius}")
        h = 0.5 * (z1 - z0)
        ang = np.linspace(0, 2 * np.pi, segments + 1)
        ring = np.stack([radius * np.cos(ang), radius * np.sin(ang)], axis=1)
        arc = radius * ang / tile_m
        mesh = _Mesh()
        for k in range(segments):
            a, b = ring[k], ring[k + 1]
            pts = [(a[0], a[1], -h), (b[0], b[1], -h), (b[0], b[1], h), (a[0], a[1], h)]
            uvs = [(arc[k], h / tile_m), (arc[k + 1], h / tile_m), (arc[k + 1], -h / tile_m), (arc[k], -h / tile_m)]
            mid = 0.5 * (a + b)
            mesh.quad(pts, uvs, (mid[0], mid[1], 0.0))
            for zc in (h, -h):
                mesh.tri([(0, 0, zc), (a[0], a[1], zc), (b[0], b[1], zc)],
                         [(0, 0), (a[0] / tile_m, a[1] / tile_m), (b[0] / tile_m, b[1] / tile_m)], (0, 0, zc))
        cx, cy = map(float, center_xy)
        fp = Footprint(STATIC_PREFIX + part, category, (cx, cy), radius=float(radius), z_range=(z0, z1))
        return self._add_mesh_geom(part, mesh, (cx, cy, 0.5 * (z0 + z1)), material, category, fp)

    def ellipsoid(self, part, center, radii, material, tile_m=1.0, n_lat=8, n_lon=16,
                  category="object") -> str:
        """Faceted ellipsoid (latitude-longitude quads, triangles at the poles)."""
        radii = np.asarray(radii, float)
        th = np.linspace(0, np.pi, n_lat + 1)                     # polar angle from +z
        ph = np.linspace(0, 2 * np.pi, n_lon + 1)

        def P(i, j):
            return radii * np.array([np.sin(th[i]) * np.cos(ph[j]), np.sin(th[i]) * np.sin(ph[j]), np.cos(th[i])])

        def UV(i, j):
            return (radii[0] * ph[j] / tile_m, radii[2] * th[i] / tile_m)

        mesh = _Mesh()
        for i in range(n_lat):
            for j in range(n_lon):
                ids = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                if i == 0:
                    ids = ids[:3]
                elif i == n_lat - 1:
                    ids = [ids[0], ids[1], ids[3]]
                pts = [P(*q) for q in ids]
                out = np.mean(pts, axis=0) / radii ** 2
                (mesh.tri if len(ids) == 3 else mesh.quad)(pts, [UV(*q) for q in ids], out)
        center = np.asarray(center, float)
        fp = Footprint(STATIC_PREFIX + part, category, tuple(center[:2]), tuple(radii[:2]), 0.0,
                       float(max(radii[:2])), (center[2] - radii[2], center[2] + radii[2]))
        return self._add_mesh_geom(part, mesh, center, material, category, fp)

    def strip(self, part, path_xy, width, material, z_top=0.0, thickness=0.02, tile_m=1.0,
              closed=True, category="path") -> str:
        """Flat slab of ``width`` (m) along a polyline (N, 2); top face at ``z_top``."""
        xy = np.asarray(path_xy, float)
        nxt = np.roll(xy, -1, 0) if closed else np.vstack([xy[1:], 2 * xy[-1] - xy[-2]])
        prv = np.roll(xy, 1, 0) if closed else np.vstack([2 * xy[0] - xy[1], xy[:-1]])
        t = nxt - prv
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        n = np.stack([-t[:, 1], t[:, 0]], axis=1)
        left, right = xy + 0.5 * width * n, xy - 0.5 * width * n
        s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
        zc = z_top - 0.5 * thickness
        mesh = _Mesh()
        idx = list(range(len(xy))) + ([0] if closed else [])
        s_ext = list(s) + ([s[-1] + np.linalg.norm(xy[0] - xy[-1])] if closed else [])
        for a, b, sa, sb in zip(idx[:-1], idx[1:], s_ext[:-1], s_ext[1:]):
            for z, nz in ((thickness / 2, 1.0), (-thickness / 2, -1.0)):
                pts = [(*right[a], z), (*right[b], z), (*left[b], z), (*left[a], z)]
                uv = [(sa / tile_m, 0), (sb / tile_m, 0), (sb / tile_m, width / tile_m), (sa / tile_m, width / tile_m)]
                mesh.quad(pts, uv, (0, 0, nz))
            for side, sgn in ((left, 1.0), (right, -1.0)):
                pts = [(*side[a], -thickness / 2), (*side[b], -thickness / 2), (*side[b], thickness / 2),
                       (*side[a], thickness / 2)]
                nn = sgn * 0.5 * (n[a] + n[b])
                mesh.quad(pts, [(0, 0), (1, 0), (1, 1), (0, 1)], (nn[0], nn[1], 0.0))
        lo, hi = xy.min(0), xy.max(0)
        fp = Footprint(STATIC_PREFIX + part, category, tuple(0.5 * (lo + hi)), tuple(0.5 * (hi - lo)),
                       z_range=(z_top - thickness, z_top))
        return self._add_mesh_geom(part, mesh, (0.0, 0.0, zc), material, category, fp)

    def mesh_instance(self, part, meshname, pos, yaw, material, half_xy, z_range, category="object") -> str:
        """A static geom of the existing mesh asset ``meshname`` at ``pos`` (3,) turned by ``yaw``; its footprint
        is the rectangle ``half_xy`` (m) about ``pos``, ``z_range`` above ``pos[2]``."""
        name = self._geom_name(part)
        pos = np.asarray(pos, float)
        self.spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=meshname,
                                     pos=list(map(float, pos)), quat=[float(np.cos(yaw / 2)), 0.0, 0.0,
                                                                      float(np.sin(yaw / 2))],
                                     material=material, contype=0, conaffinity=0, group=0)
        self.footprints.append(Footprint(name, category, tuple(pos[:2]), tuple(map(float, half_xy)), float(yaw),
                                         0.0, (pos[2] + z_range[0], pos[2] + z_range[1])))
        return name

    def plane(self, part, center, half_xy, material, category="ground") -> str:
        """Finite rendered plane (ground/floor), normal +z."""
        name = self._geom_name(part)
        material = self.instance_material(material, part, 4.0 * float(half_xy[0]) * float(half_xy[1]), decals=False)
        self.spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                     size=[float(half_xy[0]), float(half_xy[1]), 1.0],
                                     pos=list(map(float, center)), material=material,
                                     contype=0, conaffinity=0)
        self.footprints.append(Footprint(name, category, tuple(center[:2]), tuple(half_xy), 0.0, 0.0,
                                         (center[2], center[2])))
        return name

    # ------------------------------------------------------------------ lights / visual
    def light(self, name, pos, direction, diffuse=0.6, directional=True, specular=0.1):
        """Light with diffuse scaled by ``lighting``; casts shadows only if ``shadows``."""
        lt = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL if directional else mujoco.mjtLightType.mjLIGHT_SPOT
        d = float(np.clip(diffuse * self.lighting, 0, 1.5))
        self.spec.worldbody.add_light(name=f"static/{name}", type=lt, pos=list(map(float, pos)),
                                      dir=list(map(float, direction)), diffuse=[d] * 3,
                                      specular=[specular] * 3, ambient=[0.0] * 3,
                                      castshadow=self.shadows)

    def visual_defaults(self, ambient=0.35, headlight=0.25, sky=None):
        """Headlight (ambient + weak diffuse) scaled by ``lighting``; near/far clip 5 cm / 200 m."""
        sp = self.spec
        a = float(np.clip(ambient * self.lighting, 0, 1))
        h = float(np.clip(headlight * self.lighting, 0, 1))
        sp.visual.headlight.ambient = [a] * 3
        sp.visual.headlight.diffuse = [h] * 3
        sp.visual.headlight.specular = [0.0] * 3
        sp.stat.extent = 10.0                      # clip planes are relative to the extent
        sp.visual.map.znear = 0.005                # 5 cm
        sp.visual.map.zfar = 20.0                  # 200 m
        if self.shadows:
            sp.visual.quality.shadowsize = 2048
        if sky is not None:                        # cheap gradient skybox (no image texture)
            sp.add_texture(name="tex/sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                           builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, width=64, height=64,
                           rgb1=list(sky[0]), rgb2=list(sky[1]))

    def object_ids(self) -> dict:
        """Geom name -> stable integer id (1-based, sorted by name; 0 is left for background)."""
        return {name: k + 1 for k, name in enumerate(sorted(self._names))}
