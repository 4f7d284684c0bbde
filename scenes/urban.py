"""Seed 002's urban canyon: a four-lane main street crossed by a second street, multi-storey buildings on
both sides, sidewalks, road markings, street furniture, parked cars and moving actors.

World frame: x east, y north, z up, road surface at z = 0 (``ground_height`` is 0). The main street runs
along y = 0 for x in [-420, 80], the cross street along x = 0 for y in [-500, 80]; they meet at the origin.
Each street is :data:`ROAD_HALF` = 9.5 m either side of its centre line: two 3.5 m lanes per direction
(centres 1.75 m and 5.25 m from the centre line) and a 2.5 m parking lane; 4 m sidewalks (15 cm curb)
and then the building line at 13.5 m, so the canyon is 27 m wide between facades 12-40 m tall.

Route (right-hand traffic): east in the outer eastbound lane (y = -5.25) from x = -400, a stop at the
stop line before the intersection, a right turn of radius :data:`TURN_RADIUS` into the outer southbound
lane of the cross street (x = -5.25), south to y = -280: 394.75 + 274.75 - 2 r + pi r / 2 = 665.6 m (r = 9 m,
the widest turn that stays 2.3 m clear of the curb corner; a brisk turn from the stop: the car reaches
6.7 m/s and 5.3 m/s^2 lateral acceleration in it).
GCPs G01..G08 on the centre line at equal arc lengths.

Moving actors (:mod:`scenes.urban_actors`) use the other lanes (so none drives through the vehicle):
eastbound inner lane (overtaking or falling behind), both westbound lanes (oncoming), the cross street's
northbound lanes and its southbound inner lane (crossing ahead of the vehicle while it waits), pedestrians
on every sidewalk and on the north and east crossings. ``scene.dynamic_density`` is the fraction of them
that move. ``scene.time_of_day = dusk`` lowers a warm sun to 8 deg above the western horizon, dims the
ambient light and darkens the sky (seed 002's Urban Canyon 2 was recorded in the evening).
"""
from __future__ import annotations

import numpy as np

from scenes.base import GcpSite, Route
from scenes.built import BuiltScene
from scenes.errors import SceneError
from scenes.routes import point_at, resample, rounded_polyline
from scenes.urban_actors import (Lane, actor_poses, add_actors, draw_actors, first_contact,
                                 segmentation_rows)
from scenes.urban_furniture import add_furniture, add_markings, add_parked_cars

ROAD_HALF = 9.5
SIDEWALK_W = 4.0
CURB_H = 0.15
BUILDING_LINE = ROAD_HALF + SIDEWALK_W
MAIN_X = (-420.0, 80.0)
CROSS_Y = (-500.0, 80.0)
LANE = 5.25                  # outer lane centre offset (m)
TURN_RADIUS = 9.0
ROUTE_CORNERS = ((-400.0, -LANE), (-LANE, -LANE), (-LANE, -280.0))
STOP_X = -19.0               # body origin at the stop (the car's front 2.2 m further, at the stop line)
STOP_DWELL_S = 4.0
CRUISE_MPS = 10.0
ACCEL_MPS2 = 1.5
ROAD_PIECE_M = 30.0          # asphalt pieces, each with its own texture
WALK_PIECE_M = 50.0          # sidewalk pieces


class UrbanScene(BuiltScene):
    """Street canyon with an intersection, parked cars and seeded moving cars and pedestrians."""

    name = "urban"
    has_actors = True
    corridor_half_width_m = 1.5
    corridor_height_m = 3.0

    def __init__(self, config, streams, dynamic=None):
        """``dynamic``: the generator the actors are drawn from (the simulator passes its ``dynamic`` stream);
        None draws them from the scene stream ``urban/dynamic`` (scene-only use, e.g. plots)."""
        super().__init__(config, streams)
        if dynamic is not None and not isinstance(dynamic, np.random.Generator):
            raise SceneError(f"scene 'urban': dynamic must be a numpy Generator, got {type(dynamic).__name__}")
        self._path = rounded_polyline(ROUTE_CORNERS, TURN_RADIUS, step=0.25, closed=False)
        rng = dynamic if dynamic is not None else self.rng("dynamic")
        self.actors = draw_actors(actor_lanes(), float(config.dynamic_density), rng)

    @property
    def path_xy(self) -> np.ndarray:
        return self._path

    @property
    def route(self) -> Route:
        wp = resample(self._path, 2.0, closed=False)
        return Route(tuple(map(tuple, wp.round(4))), closed=False, cruise_speed_mps=CRUISE_MPS,
                     accel_mps2=ACCEL_MPS2, stops_m=(self.stop_arc_m(),), stop_dwell_s=STOP_DWELL_S)

    def stop_arc_m(self) -> float:
        """Arc length of the stop before the intersection (the route's first leg is straight)."""
        return float(STOP_X - ROUTE_CORNERS[0][0])

    @property
    def gcp_sites(self) -> tuple:
        L = self.route_length()
        xy = point_at(self._path, (np.arange(8) + 0.5) * L / 8, closed=False)
        return tuple(GcpSite(f"G{k + 1:02d}", float(x), float(y)) for k, (x, y) in enumerate(xy.round(3)))

    def extent_xy(self) -> tuple:
        return (MAIN_X[0] - 10, MAIN_X[1] + 40, CROSS_Y[0] - 10, CROSS_Y[1] + 40)

    def actor_states(self, t_ns: int) -> dict:
        """``{mocap body name: T_w_actor}`` at ``t_ns`` (what the renderer poses each frame)."""
        return actor_poses(self.actors, t_ns)

    def actor_truth(self, t_ns) -> list:
        return [(a.actor_id, a.kind, a.moving, a.poses(t_ns)) for a in self.actors]

    def first_contact(self, t_ns, T_w_b, footprint):
        return first_contact(self.actors, t_ns, T_w_b, footprint)

    def segmentation_rows(self, geom_names) -> list:
        return segmentation_rows(geom_names, self.actors)

    # ------------------------------------------------------------------ build
    def _build(self, b) -> None:
        self._lights(b)
        self._ground(b)
        self._buildings(b, self.rng("buildings"))
        add_markings(b, ROAD_HALF, MAIN_X, CROSS_Y)
        add_furniture(b, self.rng("furniture"), street_segments(), ROAD_HALF, BUILDING_LINE, CURB_H)
        add_parked_cars(b, self.rng("parked"), street_segments(), ROAD_HALF)
        add_actors(b.spec, b, self.actors)

    def _lights(self, b) -> None:
        if self.config.time_of_day == "dusk":
            b.visual_defaults(ambient=0.18, headlight=0.08, sky=((0.25, 0.2, 0.3), (0.85, 0.55, 0.35)))
            b.light("sun", (0, 0, 60), (np.cos(np.radians(8)), 0.15, -np.sin(np.radians(8))), diffuse=0.55)
            _tint(b.spec, "static/sun", (1.0, 0.72, 0.45))
            b.light("fill", (0, 0, 60), (-0.3, -0.4, -0.85), diffuse=0.12)
            _tint(b.spec, "static/fill", (0.55, 0.6, 0.85))
        else:
            b.visual_defaults(ambient=0.4, headlight=0.2, sky=((0.55, 0.7, 0.9), (0.85, 0.88, 0.92)))
            b.light("sun", (0, 0, 60), (-0.35, -0.25, -0.9), diffuse=0.6)
            b.light("fill", (0, 0, 60), (0.4, 0.5, -0.75), diffuse=0.25)

    def _ground(self, b) -> None:
        """Base plane, asphalt and sidewalks; the long surfaces in pieces (:data:`ROAD_PIECE_M`,
        :data:`WALK_PIECE_M`) so that each stretch has its own texture: no two distant places show the same
        road (one repeating tile along 500 m is the look-alike a loop closure falls for)."""
        b.plane("ground/base", (-170, -200, -0.02), (300, 330), b.material("concrete", plane_tile_m=4.0))
        asphalt, walk = b.material("asphalt", size=256), b.material("pavement", size=256)
        for j, (x0, x1) in enumerate(_pieces(*MAIN_X, ROAD_PIECE_M)):
            b.box(f"road/main/{j}", ((x0 + x1) / 2, 0, -0.01), ((x1 - x0) / 2, ROAD_HALF, 0.01), asphalt,
                  tile_m=2.0, category="path")
        for name, y0, y1 in (("cross_s", CROSS_Y[0], -ROAD_HALF), ("cross_n", ROAD_HALF, CROSS_Y[1])):
            for j, (a, c) in enumerate(_pieces(y0, y1, ROAD_PIECE_M)):
                b.box(f"road/{name}/{j}", (0, (a + c) / 2, -0.01), (ROAD_HALF, (c - a) / 2, 0.01), asphalt,
                      tile_m=2.0, category="path")
        for k, (x0, x1, y0, y1) in enumerate(sidewalk_rects()):
            along_x = x1 - x0 > y1 - y0
            for j, (a, c) in enumerate(_pieces(*((x0, x1) if along_x else (y0, y1)), WALK_PIECE_M)):
                xa, xb, ya, yb = (a, c, y0, y1) if along_x else (x0, x1, a, c)
                b.box(f"sidewalk{k}/{j}", ((xa + xb) / 2, (ya + yb) / 2, CURB_H / 2),
                      ((xb - xa) / 2, (yb - ya) / 2, CURB_H / 2), walk, tile_m=2.0, category="ground")

    def _buildings(self, b, rng) -> None:
        k = 0
        for seg in street_segments():
            for side in (1, -1):
                t = seg.t0 + rng.uniform(0.0, 3.0)
                while t < seg.t1 - 6.0:
                    w = min(rng.uniform(10.0, 24.0), seg.t1 - t)
                    self._building(b, rng, k, seg, side, t + w / 2, w)
                    k += 1
                    t += w + (rng.uniform(1.0, 4.0) if rng.random() < 0.3 else 0.0)

    def _building(self, b, rng, k, seg, side, t_mid, w) -> None:
        storeys = int(rng.integers(3, 11))
        h, depth = 4.0 * storeys, rng.uniform(12.0, 18.0)
        off = side * (BUILDING_LINE + depth / 2)
        ctr = seg.point(t_mid, off)
        yaw = seg.yaw
        mat = b.material("facade", variant=int(rng.integers(0, 10)))
        b.box(f"building{k}", (*ctr, h / 2), (w / 2, depth / 2, h / 2), mat, yaw=yaw, tile_m=4.0,
              category="building")
        if rng.random() < 0.6 and w > 6:
            front = seg.point(t_mid, side * (BUILDING_LINE - 0.08))
            b.box(f"building{k}/shop", (*front, 1.8), (w / 2 - 1.0, 0.08, 1.8),
                  b.material("poster", variant=int(rng.integers(0, 12)), size=128), yaw=yaw, tile_m=3.6,
                  category="building")


def _pieces(t0: float, t1: float, length: float) -> list:
    """``[(a, b), ...]``: ``[t0, t1]`` cut into equal pieces of at most ``length``."""
    n = max(1, int(np.ceil((t1 - t0) / length)))
    edges = np.linspace(t0, t1, n + 1)
    return list(zip(edges[:-1], edges[1:]))


class Segment:
    """A straight street section: centre line along ``axis`` ("x" or "y") from ``t0`` to ``t1``."""

    def __init__(self, axis: str, t0: float, t1: float):
        self.axis, self.t0, self.t1 = axis, float(t0), float(t1)
        self.yaw = 0.0 if axis == "x" else np.pi / 2

    def point(self, t, offset) -> np.ndarray:
        """World (x, y) at along-street ``t`` and lateral ``offset`` (positive = left of +axis)."""
        return np.array([t, offset]) if self.axis == "x" else np.array([-offset, t])


def street_segments() -> tuple:
    """Street sections between the intersection and the street ends (buildings, sidewalks, parking)."""
    e = BUILDING_LINE
    return (Segment("x", MAIN_X[0], -e), Segment("x", e, MAIN_X[1]),
            Segment("y", CROSS_Y[0], -e), Segment("y", e, CROSS_Y[1]))


def sidewalk_rects() -> tuple:
    """(x0, x1, y0, y1) of the sidewalks; the main street's own the four corner squares."""
    r, e = ROAD_HALF, BUILDING_LINE
    return ((MAIN_X[0], -r, -e, -r), (MAIN_X[0], -r, r, e), (r, MAIN_X[1], -e, -r), (r, MAIN_X[1], r, e),
            (-e, -r, CROSS_Y[0], -e), (r, e, CROSS_Y[0], -e), (-e, -r, e, CROSS_Y[1]), (r, e, e, CROSS_Y[1]))


def actor_lanes() -> tuple:
    """Where the actors move (see the module doc); counts and speed ranges per lane.

    The two ``route_lane`` platoons drive ahead of the vehicle in its own lanes, placed for the default
    motion (start at 1 s, no rest, 10 m/s cruise, 1.5 m/s^2 ramps, at rest at the stop line from about 52 s to
    57 s after the start): the eastbound platoon (10 m/s, from rest with the vehicle) starts 24 m ahead and
    stays 13 m or more ahead (centre to centre) while the vehicle brakes for the stop; the southbound platoon (8 m/s) crosses the
    junction from the north while the vehicle waits; its nearest car is on average 37 m ahead on the cross
    street
    (every generation checks the clearance, :func:`sim.generate.check_clearance`: another
    ``motion.cruise_speed_mps`` above 10 m/s reaches them and is refused)."""
    e, r = 1.75, ROAD_HALF
    walk = (r + BUILDING_LINE) / 2
    east, west, north, south = 0.0, np.pi, np.pi / 2, -np.pi / 2
    return (
        Lane("car", (0.0, -LANE), east, (-397.0, -277.0), (9.9, 10.1), 4, bus_share=0.6, route_lane=True,
             jitter=0.0, start_tau_s=7.3),                                       # ahead in the vehicle's lanes
        Lane("car", (-LANE, 0.0), south, (-464.5, -414.5), (7.95, 8.05), 2, bus_share=0.5, route_lane=True,
             jitter=0.0),
        Lane("car", (0.0, -e), east, (-700.0, -100.0), (8.5, 12.5), 40, bus_share=0.5, jitter=0.05),   # overtake / fall behind
        Lane("car", (0.0, e), west, (-400.0, 800.0), (8.0, 12.0), 80, bus_share=0.4, jitter=0.05),   # oncoming
        Lane("car", (0.0, LANE), west, (-400.0, 800.0), (7.0, 11.0), 50),
        Lane("car", (e, 0.0), north, (-1600.0, -300.0), (8.0, 12.0), 80, bus_share=0.4, jitter=0.05),   # crossing, then oncoming
        Lane("car", (LANE, 0.0), north, (-1600.0, -300.0), (7.0, 11.0), 52),
        Lane("car", (-e, 0.0), south, (450.0, 800.0), (9.5, 11.5), 24, bus_share=0.5, jitter=0.05),  # ahead after the turn
        Lane("pedestrian", (0.0, -walk), east, (-420.0, 0.0), (1.0, 1.6), 36),
        Lane("pedestrian", (0.0, walk), west, (-60.0, 420.0), (1.0, 1.6), 36),
        Lane("pedestrian", (-walk, 0.0), south, (0.0, 500.0), (1.0, 1.6), 26),
        Lane("pedestrian", (walk, 0.0), north, (-500.0, 0.0), (1.0, 1.6), 26),
        Lane("pedestrian", (0.0, 13.0), east, (-1.0, 1.0), (1.1, 1.5), 3, mode="shuttle", width_m=2 * r),
        Lane("pedestrian", (13.0, 0.0), north, (-1.0, 1.0), (1.1, 1.5), 3, mode="shuttle", width_m=2 * r),
    )


def _tint(spec, light_name: str, rgb) -> None:
    """Multiply a light's (grey) diffuse colour by ``rgb``."""
    for lt in spec.lights:
        if lt.name == light_name:
            lt.diffuse = [float(lt.diffuse[i]) * c for i, c in enumerate(rgb)]
