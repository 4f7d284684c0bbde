"""Seed 000's outdoor test field: a ~90 m closed loop around a museum-like building.

World frame: x east, y north, z up; the museum (18.5 m x 12.5 m x 8 m) is centred at the origin.
The route is the offset curve of the footprint at 4.5 m (straight legs plus quarter circles of
radius 4.5 m around the building's corners), 2(18.5 + 12.5) + 2*pi*4.5 = 90.27 m, driven counter-
clockwise from the middle of the south side.  The paper's total GCP length is 91.175 m.

Ground: flat.  ``ground_height`` is 0 everywhere; the paved path strip's top face is exactly at
z = 0 and the surrounding lawn plane lies 5 mm lower (invisible to the cameras, avoids z-fighting),
so the surface the vehicle drives on matches ``ground_height`` exactly.
"""
from __future__ import annotations

import numpy as np

from scenes.base import GcpSite, Route
from scenes.built import BuiltScene
from scenes.routes import point_at, resample, rounded_polyline

BUILDING_HALF = (9.25, 6.25)   # m
BUILDING_H = 8.0
PATH_OFFSET = 4.5              # route distance from the facades (m)
PATH_WIDTH = 3.2               # paved strip width (m)


def _loop_corners():
    hx, hy = BUILDING_HALF[0] + PATH_OFFSET, BUILDING_HALF[1] + PATH_OFFSET
    return [(0.0, -hy), (hx, -hy), (hx, hy), (-hx, hy), (-hx, -hy)]


class CampusScene(BuiltScene):
    """Outdoor loop around a textured museum, with trees, lamps, benches, hedges and buildings."""

    name = "campus"
    corridor_half_width_m = 1.5
    corridor_height_m = 3.0

    def __init__(self, config, streams):
        super().__init__(config, streams)
        self._path = rounded_polyline(_loop_corners(), PATH_OFFSET, step=0.1, closed=True)

    @property
    def path_xy(self) -> np.ndarray:
        return self._path

    @property
    def route(self) -> Route:
        wp = resample(self._path, 2.0, closed=True)
        return Route(tuple(map(tuple, wp.round(4))), closed=True, cruise_speed_mps=1.2, accel_mps2=0.4)

    @property
    def gcp_sites(self) -> tuple:
        L = self.route_length()
        s = (np.arange(7) + 0.5) * L / 7
        xy = point_at(self._path, s, closed=True)
        return tuple(GcpSite(f"C{k + 1:02d}", float(x), float(y)) for k, (x, y) in enumerate(xy.round(3)))

    def extent_xy(self) -> tuple:
        return (-45.0, 45.0, -40.0, 40.0)

    # ------------------------------------------------------------------ build
    def _build(self, b) -> None:
        b.visual_defaults(ambient=0.4, headlight=0.2, sky=((0.55, 0.7, 0.9), (0.85, 0.88, 0.92)))
        b.light("sun", (0, 0, 30), (-0.35, -0.25, -0.9), diffuse=0.6)
        b.light("fill", (0, 0, 30), (0.4, 0.5, -0.75), diffuse=0.25)
        self._ground(b)
        self._museum(b, self.rng("museum"))
        self._path_furniture(b, self.rng("furniture"))
        self._surroundings(b, self.rng("surroundings"))

    def _ground(self, b):
        b.plane("ground/lawn", (0, 0, -0.005), (60, 60), b.material("grass", plane_tile_m=2.0))
        b.strip("ground/path", self._path, PATH_WIDTH, b.material("pavement", size=512), tile_m=2.4)
        hx, hy = BUILDING_HALF
        apron = PATH_OFFSET - PATH_WIDTH / 2 - 0.05
        mat = b.material("concrete", variant=1)
        for name, c, h in (("s", (0, -hy - apron / 2), (hx, apron / 2)), ("n", (0, hy + apron / 2), (hx, apron / 2)),
                           ("e", (hx + apron / 2, 0), (apron / 2, hy)), ("w", (-hx - apron / 2, 0), (apron / 2, hy))):
            b.box(f"ground/apron_{name}", (c[0], c[1], -0.012), (h[0], h[1], 0.01), mat, tile_m=2.0,
                  category="ground")

    def _sides(self):
        """(name, centre on facade, outward normal, along-facade unit, half length) of the museum."""
        hx, hy = BUILDING_HALF
        return (("s", np.array([0, -hy]), np.array([0, -1.0]), np.array([1.0, 0]), hx),
                ("e", np.array([hx, 0]), np.array([1.0, 0]), np.array([0, 1.0]), hy),
                ("n", np.array([0, hy]), np.array([0, 1.0]), np.array([-1.0, 0]), hx),
                ("w", np.array([-hx, 0]), np.array([-1.0, 0]), np.array([0, -1.0]), hy))

    def _museum(self, b, rng):
        hx, hy = BUILDING_HALF
        b.box("museum/core", (0, 0, BUILDING_H / 2), (hx, hy, BUILDING_H / 2), b.material("plaster"),
              tile_m=3.0, category="building")
        b.box("museum/parapet", (0, 0, BUILDING_H + 0.3), (hx + 0.2, hy + 0.2, 0.3),
              b.material("concrete", variant=2), tile_m=3.0, category="building")
        for side, c, n, u, half in self._sides():
            yaw = float(np.arctan2(u[1], u[0]))
            npan = int(round(2 * half / 4.0))
            w = 2 * half / npan
            for k in range(npan):
                for storey in range(2):
                    ctr = c + n * 0.05 + u * (-half + (k + 0.5) * w)
                    b.box(f"museum/{side}/panel{k}_{storey}", (*ctr, 2.0 + 4.0 * storey), (w / 2, 0.05, 2.0),
                          b.material("facade", variant=int(rng.integers(0, 6)), size=512), yaw=yaw,
                          tile_m=4.0, category="building")
            door = c + n * 0.16
            b.box(f"museum/{side}/door", (*door, 1.2), (0.9, 0.06, 1.2), b.material("wood", variant=1),
                  yaw=yaw, tile_m=1.8, category="building")
            b.box(f"museum/{side}/sign", (*(c + n * 0.14), 2.9), (1.6, 0.04, 0.35),
                  b.material("poster", variant=int(rng.integers(20, 24))), yaw=yaw, tile_m=3.2,
                  category="building")
            for k, t in enumerate(rng.uniform(0.25, 0.85, 2) * half * np.array([-1, 1])):
                p = c + n * 0.13 + u * t
                b.box(f"museum/{side}/poster{k}", (*p, 1.7), (0.45, 0.03, 0.65),
                      b.material("poster", variant=int(rng.integers(0, 8))), yaw=yaw, tile_m=1.0,
                      category="building")
            if side in ("e", "w"):
                p = c + n * 0.14 + u * half * 0.55
                b.box(f"museum/{side}/graffiti", (*p, 1.0), (1.2, 0.03, 0.9),
                      b.material("graffiti", variant=int(rng.integers(0, 3))), yaw=yaw, tile_m=2.4,
                      category="building")
            bench = c + n * 1.3 + u * half * rng.choice([-0.5, 0.5])
            self._bench(b, f"museum/{side}/bench", bench, yaw)
        for k, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
            b.cylinder(f"museum/drainpipe{k}", (sx * (hx + 0.12), sy * (hy + 0.12)), 0.0, BUILDING_H,
                       0.06, b.material("concrete", variant=3), tile_m=1.0, segments=8)

    def _bench(self, b, part, xy, yaw):
        mat = b.material("wood", variant=2)
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        b.box(part + "/seat", (*xy, 0.45), (0.9, 0.22, 0.03), mat, yaw=yaw, tile_m=1.0, category="furniture")
        b.box(part + "/back", (*(xy + R @ (0, -0.2)), 0.75), (0.9, 0.03, 0.22), mat, yaw=yaw, tile_m=1.0,
              category="furniture")
        b.box(part + "/base", (*xy, 0.21), (0.75, 0.15, 0.21), b.material("concrete", variant=3), yaw=yaw,
              tile_m=1.0, category="furniture")

    def _outward(self, s):
        """Points on the path at arc lengths s and the outward unit normals there."""
        p = point_at(self._path, s, closed=True)
        q = point_at(self._path, np.asarray(s) + 0.2, closed=True)
        t = (q - p) / np.linalg.norm(q - p, axis=1, keepdims=True)
        return p, np.stack([t[:, 1], -t[:, 0]], axis=1)           # counter-clockwise loop: right = out

    def _path_furniture(self, b, rng):
        L = self.route_length()
        s_lamp = np.arange(8) * L / 8 + 3.0
        p, n = self._outward(s_lamp)
        for k, (pk, nk) in enumerate(zip(p, n)):
            q = pk + nk * 2.3
            b.cylinder(f"lamp{k}/pole", q, 0.0, 4.5, 0.07, b.material("concrete", variant=4), segments=10)
            b.box(f"lamp{k}/head", (*q, 4.6), (0.3, 0.12, 0.1), b.material("concrete", variant=4),
                  yaw=float(np.arctan2(nk[1], nk[0])))
            if k % 2 == 0:
                b.cylinder(f"bin{k}", pk + nk * 2.0 + np.array([-nk[1], nk[0]]) * 0.8, 0.0, 0.9, 0.25,
                           b.material("graffiti", variant=5), tile_m=1.2, segments=12)
        s_tree = np.arange(12) * L / 12 + 6.0 + rng.uniform(-1.0, 1.0, 12)
        p, n = self._outward(s_tree)
        for k, (pk, nk) in enumerate(zip(p, n)):
            q = pk + nk * rng.uniform(4.0, 4.8)
            trunk_h = rng.uniform(2.4, 3.0)
            b.cylinder(f"tree{k}/trunk", q, 0.0, trunk_h, rng.uniform(0.14, 0.22), b.material("bark"),
                       tile_m=1.0, segments=10, category="tree")
            rxy, rz = rng.uniform(1.2, 1.6), rng.uniform(1.5, 2.0)
            b.ellipsoid(f"tree{k}/crown", (*q, trunk_h + 0.7 * rz), (rxy, rxy * rng.uniform(0.85, 1.0), rz),
                        b.material("foliage", variant=int(k % 3)), tile_m=1.5, category="tree")
        s_hedge = np.arange(0, L, 7.0)
        p, n = self._outward(s_hedge + 3.5)
        for k, (pk, nk) in enumerate(zip(p, n)):
            if rng.random() < 0.25:
                continue
            q = pk + nk * 7.0
            b.box(f"hedge{k}", (*q, 0.6), (rng.uniform(2.0, 3.0), 0.45, 0.6),
                  b.material("foliage", variant=3 + int(k % 2)), yaw=float(np.arctan2(-nk[0], nk[1])),
                  tile_m=1.5, category="hedge")

    def _surroundings(self, b, rng):
        """Walls and other buildings 9-25 m outside the loop so outward views are textured."""
        hx, hy = BUILDING_HALF[0] + PATH_OFFSET, BUILDING_HALF[1] + PATH_OFFSET
        sides = ((np.array([0, -hy]), np.array([0, -1.0]), np.array([1.0, 0]), hx + 12),
                 (np.array([hx, 0]), np.array([1.0, 0]), np.array([0, 1.0]), hy + 12),
                 (np.array([0, hy]), np.array([0, 1.0]), np.array([-1.0, 0]), hx + 12),
                 (np.array([-hx, 0]), np.array([-1.0, 0]), np.array([0, -1.0]), hy + 12))
        k = 0
        for si, (c, n, u, half) in enumerate(sides):
            yaw = float(np.arctan2(u[1], u[0]))
            wall = c + n * 10.0
            b.box(f"wall{si}", (*wall, 1.1), (half - 10, 0.15, 1.1),
                  b.material("graffiti" if si % 2 else "brick", variant=si), yaw=yaw, tile_m=2.5,
                  category="wall")
            t = -half
            while t < half - 4:
                w = min(rng.uniform(8.0, 16.0), half - t)
                d, h = rng.uniform(6.0, 10.0), rng.uniform(5.0, 14.0)
                ctr = c + n * (rng.uniform(14.0, 18.0) + d / 2) + u * (t + w / 2)
                kind = ("facade", 6 + int(rng.integers(0, 6)), 256) if rng.random() < 0.7 else \
                       ("brick", int(rng.integers(1, 4)), 256)
                b.box(f"building{k}", (*ctr, h / 2), (w / 2, d / 2, h / 2),
                      b.material(kind[0], variant=kind[1], size=kind[2]), yaw=yaw, tile_m=4.0,
                      category="building")
                k += 1
                t += w + rng.uniform(2.0, 5.0)
