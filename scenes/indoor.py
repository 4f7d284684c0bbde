"""Seed 000's indoor test field: a 16 m x 12 m floor, ~21 m open route, GCPs P01..P03.

World frame: the floor spans x in [0, 16], y in [0, 12] (z up, floor at z = 0, ceiling at 3 m).
Rooms: south-west room S1 (y < 5, x < 8), south-east S2, a corridor (5 < y < 7.5), north-west
room N1 (x < 6) and north-east room N2.  The route starts in S1 heading east, turns north through a
2.6 m doorway into the corridor, east along it, north through a doorway into N2 and west along
y = 10.2 along a texture-poor white wall (the north wall, 1.8 m away; the N1/N2 partition ahead is plaster):
as in the paper, P03 lies next to a texture-poor white wall < 2 m away, which also fills the view
while the cart drives north towards it.
Those walls are near-white with very low-contrast paint at every ``texture_richness`` (a perfectly
blank surface would give zero features, which no real wall does; seed 000 reports fewer, not none), and,
as real walls, a skirting board, sockets, switches and a few notices. Every wall side has a texture of its
own drawn at its full extent (:mod:`scenes.indoor_walls`): no pattern repeats within a wall or between walls.
Every poster, every desk top and every item on a desk has a pattern of its own (:func:`own_material`,
:func:`own_drawn`), not a tint of a shared one: two copies of one poster 11 m apart were a look-alike place
(``validate places``, seed 4). Posters and desk items are prints laid out as real ones (:mod:`scenes.indoor_print`:
headline, photo, word-blob text), not rows of alike glyph blocks; shelves are bookshelves of their own. The walls
around the white wall, S1's east wall, the corridor's north wall and its end carry what real walls do, each
instance its own (:mod:`scenes.indoor_fixtures`: doors, one fire-extinguisher point, pictures, whiteboards, notice
boards, clocks), with bare paint between them.

Doorways are 2.2 m high, so the free corridor checked around the route is 1 m each side up to
``corridor_height_m = 2.1`` m (the paper's cart and cameras are below 1.5 m).
"""
from __future__ import annotations

import numpy as np

from scenes.base import GcpSite, Route
from scenes.built import BuiltScene
from scenes.indoor_fixtures import add_fixtures
from scenes.indoor_print import print_image, shelf_image
from scenes.indoor_walls import add_wall
from scenes.routes import point_at, resample, rounded_polyline
from scenes.textures import make_texture, weather, with_richness

ROOM = (16.0, 12.0)
CEILING = 3.0
WALL_T = 0.2
DOOR_H = 2.2
ROUTE_CORNERS = ((1.05, 2.5), (6.25, 2.5), (6.25, 6.25), (12.0, 6.25), (12.0, 10.2), (8.0, 10.2))


def own_material(b, kind: str, part: str, stickers: bool = True, size: int = 256) -> str:
    """A material with a ``kind`` pattern of its own for the geom ``part``, whatever its size (the builder gives
    small parts a tint of the kind's shared pattern, which ORB, on grey images, still sees as one): drawn from
    stream ``texture/<kind>/<part>``, weathered from ``texture/weather/<part>`` (:func:`scenes.textures.weather`),
    as the builder's large-surface instances."""
    keys = (f"texture/{kind}/{part}", f"texture/weather/{part}")
    img = b.textures.get(tuple(b.streams(k) for k in keys), ("instance", kind, b.richness, size, bool(stickers)),
                         lambda: weather(make_texture(kind, b.streams(keys[0]), b.richness, size),
                                         b.streams(keys[1]), stickers=stickers))
    return b.image_material(f"{kind}/own/{part}", img, specular=0.1, shininess=0.1)


def own_drawn(b, kind: str, part: str, draw, size: int = 256, stickers: bool = True) -> str:
    """As :func:`own_material`, the pattern drawn by ``draw(rng, size)`` (a full-contrast float image,
    :mod:`scenes.indoor_print`) from stream ``texture/<kind>/<part>``: a print or a shelf of its own."""
    keys = (f"texture/{kind}/{part}", f"texture/weather/{part}")
    img = b.textures.get(tuple(b.streams(k) for k in keys), ("drawn", kind, b.richness, size, bool(stickers)),
                         lambda: weather(with_richness(draw(b.streams(keys[0]), size), b.richness),
                                         b.streams(keys[1]), stickers=stickers))
    return b.image_material(f"{kind}/own/{part}", img, specular=0.1, shininess=0.1)


class IndoorScene(BuiltScene):
    """Rooms, corridor, doorways, furniture, posters, a calibration board and white walls."""

    name = "indoor"
    corridor_half_width_m = 1.0
    corridor_height_m = 2.1

    def __init__(self, config, streams):
        super().__init__(config, streams)
        self._path = rounded_polyline(ROUTE_CORNERS, 1.0, step=0.05, closed=False)

    @property
    def path_xy(self) -> np.ndarray:
        return self._path

    @property
    def route(self) -> Route:
        wp = resample(self._path, 0.75, closed=False)
        return Route(tuple(map(tuple, wp.round(4))), closed=False, cruise_speed_mps=0.8, accel_mps2=0.4)

    @property
    def gcp_sites(self) -> tuple:
        L = self.route_length()
        xy = point_at(self._path, [3.0, 10.5, L - 1.5], closed=False)
        return tuple(GcpSite(f"P{k + 1:02d}", float(x), float(y)) for k, (x, y) in enumerate(xy.round(3)))

    def extent_xy(self) -> tuple:
        return (-1.0, ROOM[0] + 1.0, -1.0, ROOM[1] + 1.0)

    # ------------------------------------------------------------------ build
    def _build(self, b) -> None:
        rng = self.rng("layout")
        b.visual_defaults(ambient=0.45, headlight=0.25)
        b.light("ceiling_a", (8, 6, 2.9), (0.2, 0.3, -1.0), diffuse=0.35)
        b.light("ceiling_b", (8, 6, 2.9), (-0.3, -0.2, -1.0), diffuse=0.25)
        b.plane("floor", (8, 6, 0), (8, 6), b.material("carpet", plane_tile_m=1.5))
        b.box("ceiling", (8, 6, CEILING + 0.05), (8.2, 6.2, 0.05), b.flat_material("ceiling", (0.9, 0.9, 0.88, 1)),
              category="ceiling")
        for k, (x, y) in enumerate(((3, 2.5), (12, 2.5), (4, 6.25), (10, 6.25), (9, 9.8), (13.5, 9.8))):
            b.box(f"ceiling_light{k}", (x, y, CEILING - 0.01), (0.6, 0.3, 0.01),
                  b.flat_material("lamp", (1, 1, 0.95, 1), emission=0.8), category="ceiling")
        self._walls(b)
        self._furniture(b, rng)
        self._decor(b, rng)

    def _walls(self, b):
        W, H = ROOM
        h = WALL_T / 2
        frame = b.material("wood", variant=3)

        def wall(name, p0, p1, left="plaster", right="plaster", doors=()):
            add_wall(b, name, p0, p1, {"left": left, "right": right}, CEILING, WALL_T, DOOR_H, frame, doors)

        wall("wall/south", (-2 * h, -h), (W + 2 * h, -h), right=None)             # outer walls: one side seen
        wall("wall/west", (-h, 0), (-h, H), left=None)
        wall("wall/east", (W + h, 0), (W + h, H), right=None)
        wall("wall/north_n1", (-2 * h, H + h), (6.0, H + h), left=None)
        wall("wall/north_n2", (6.0, H + h), (W + 2 * h, H + h), left=None, right="white")    # near P03
        wall("wall/corridor_s", (0, 5.0), (W, 5.0), doors=((4.95, 7.55), (12.0, 13.2)))
        wall("wall/corridor_n", (0, 7.5), (W, 7.5), doors=((2.0, 3.2), (10.7, 13.3)))
        wall("wall/s1_s2", (8.0, 0.0), (8.0, 5.0 - h), doors=((1.5, 2.7),))
        wall("wall/n1_n2", (6.0, 7.5 + h), (6.0, H))                                      # ahead at the end
        used = set()                                      # what real walls carry, around the white wall (P03)
        add_fixtures(b, "wall/north_n2", "right", (6.0, H + h), (W, H + h), (0.0, -1.0), WALL_T, used=used)
        add_fixtures(b, "wall/n1_n2", "right", (6.0, 7.5 + h), (6.0, H), (1.0, 0.0), WALL_T, used=used)
        add_fixtures(b, "wall/n1_n2", "left", (6.0, 7.5 + h), (6.0, H), (-1.0, 0.0), WALL_T, used=used)
        add_fixtures(b, "wall/east", "corridor", (W + h, 5.0 + h), (W + h, 7.5 - h), (-1.0, 0.0), WALL_T,
                     used=used, exclude=("clock", "picture", "door"))   # the corridor's end, 10 m ahead after the
        #                                                   turn into it: a board (a clock or picture is a speck there)
        add_fixtures(b, "wall/s1_s2", "left", (8.0, 0.0), (8.0, 5.0 - h), (-1.0, 0.0), WALL_T, doors=((1.5, 2.7),),
                     used=used, keep_clear=((3.0, 5.0),), exclude=("door",))  # ahead at the start; a poster, a cabinet
        add_fixtures(b, "wall/corridor_n", "right", (0.0, 7.5), (W, 7.5), (0.0, -1.0), WALL_T,
                     doors=((2.0, 3.2), (10.7, 13.3)), used=used,   # seen from S1 through its doorway; posters
                     keep_clear=((4.3, 5.7), (7.8, 9.2), (14.3, 15.7)))

    def _desk(self, b, part, xy, yaw, rng):
        rng.integers(4, 7)                  # unused draw: the layout stream's sequence fixes where things stand
        top = own_material(b, "wood", part + "/top", stickers=False)
        b.box(part + "/top", (*xy, 0.74), (0.7, 0.38, 0.02), top, yaw=yaw, tile_m=1.2, category="furniture")
        c, s = np.cos(yaw), np.sin(yaw)
        for j, (dx, dy) in enumerate(((-0.65, -0.33), (0.65, -0.33), (-0.65, 0.33), (0.65, 0.33))):
            q = np.asarray(xy) + (c * dx - s * dy, s * dx + c * dy)
            b.box(part + f"/leg{j}", (*q, 0.36), (0.025, 0.025, 0.36), b.material("concrete", variant=5),
                  tile_m=1.0, category="furniture")
        if rng.random() < 0.8:                                   # monitor / box of papers on the desk
            rng.integers(30, 36)                                 # unused draw (layout sequence)
            b.box(part + "/item", (*xy, 0.95), (0.28, 0.04, 0.19), own_drawn(b, "print", part + "/item", print_image),
                  yaw=yaw, tile_m=0.6, category="furniture")

    def _shelf(self, b, part, xy, yaw, rng, width=1.8, height=2.0):
        rng.integers(40, 44)                                     # unused draw (layout sequence)
        b.box(part, (*xy, height / 2), (width / 2, 0.2, height / 2),
              own_drawn(b, "shelf", part, shelf_image, size=512, stickers=False), yaw=yaw,
              tile_m=max(width, height), category="furniture")

    def _furniture(self, b, rng):
        # S1: desks along the south wall, shelves along the corridor wall, cabinet, calibration board
        for k, x in enumerate((1.2, 2.8, 4.4)):
            self._desk(b, f"s1/desk{k}", (x, 0.6), 0.0, rng)
        for k, x in enumerate((1.2, 3.2)):
            self._shelf(b, f"s1/shelf{k}", (x, 4.65), np.pi, rng)
        b.box("s1/cabinet", (7.45, 0.6, 0.65), (0.3, 0.45, 0.65), b.material("wood", variant=7),
              tile_m=1.3, category="furniture")
        b.box("s1/calib_board", (7.75, 3.6, 1.45), (0.01, 0.45, 0.45), b.material("checkerboard"),
              tile_m=0.9, category="furniture")
        b.box("s1/calib_stand", (7.78, 3.6, 0.5), (0.02, 0.03, 0.5), b.material("concrete", variant=5),
              tile_m=1.0, category="furniture")
        # corridor: boxes and a cabinet at the ends (outside the route corridor)
        for k in range(4):
            x = rng.uniform(14.0, 15.6)
            y = rng.uniform(5.5, 7.0)
            s = rng.uniform(0.2, 0.35)
            b.box(f"corridor/box{k}", (x, y, s * (1 + k % 2)), (s, s, s * (1 + k % 2)),
                  b.material("noise", variant=k), yaw=float(rng.uniform(0, np.pi)), tile_m=0.8,
                  category="furniture")
        b.box("corridor/cabinet", (0.6, 6.2, 0.9), (0.3, 0.9, 0.9), b.material("wood", variant=8),
              tile_m=1.8, category="furniture")
        # N2: desks, shelves on the east wall
        for k, (x, y) in enumerate(((14.2, 8.5), (14.2, 10.8), (8.0, 8.2), (9.6, 8.2))):
            self._desk(b, f"n2/desk{k}", (x, y), 0.0 if k >= 2 else np.pi / 2, rng)
        self._shelf(b, "n2/shelf0", (15.7, 9.8), np.pi / 2, rng, width=2.4)
        # S2 (seen through the doorways): shelves and boxes
        self._shelf(b, "s2/shelf0", (12.0, 0.3), 0.0, rng, width=3.0)
        b.box("s2/boxes", (10.0, 3.6, 0.4), (0.5, 0.4, 0.4), b.material("noise", variant=5), tile_m=1.0,
              category="furniture")

    def _decor(self, b, rng):
        """Posters on the textured walls (the white wall carries fixtures only: :meth:`_walls`)."""
        hi, ho = WALL_T / 2 + 0.011, 0.011                 # inner walls are centred on their line
        spots = ((3.0, ho, 0.0), (5.8, ho, 0.0), (ho, 3.0, np.pi / 2), (8.0 - hi, 3.9, np.pi / 2),
                 (2.5, 5.0 - hi, 0.0), (9.5, 5.0 + hi, 0.0), (14.5, 5.0 + hi, 0.0),
                 (5.0, 7.5 - hi, 0.0), (8.5, 7.5 - hi, 0.0), (15.0, 7.5 - hi, 0.0),
                 (9.0, 7.5 + hi, 0.0), (16.0 - ho, 8.3, np.pi / 2))
        for k, (x, y, yaw) in enumerate(spots):
            w, hh = rng.uniform(0.3, 0.6), rng.uniform(0.4, 0.7)
            z = rng.uniform(1.4, 1.8)
            rng.integers(0, 12)                                  # unused draw (layout sequence)
            b.box(f"decor/poster{k}", (x, y, z), (w, 0.01, hh), own_drawn(b, "print", f"decor/poster{k}", print_image),
                  yaw=yaw, tile_m=2 * max(w, hh), category="decor")
