"""Static details of the urban scene: road markings, street furniture and parked cars.

Markings are 3 mm paint boxes on the asphalt (top at z = 3 mm): the double centre line, dashed lane
dividers (3 m dash, 12 m period), the parking-lane edge lines, zebra crossings on all four arms of the
intersection and the stop line of the route's approach. Furniture stands on the sidewalks (top at the
curb height): lamp posts and trees along the curb, benches and bins near the facades, traffic lights
at the four corners. Parked cars fill seeded slots of the parking lanes, away from the intersection, each
one of its own (body type, proportions, lights, windows, colour: :mod:`scenes.car_shapes`).
"""
from __future__ import annotations

import numpy as np

from scenes.actor_textures import car_atlas, car_layout
from scenes.car_shapes import draw_body
from scenes.urban_actors import parts_mesh

PAINT_Z = 0.003
DASH_M, DASH_PERIOD_M = 3.0, 12.0
PARK_SLOT_M = 6.5


def _paint(b, part, center_xy, half_xy, yaw=0.0):
    b.box(part, (*center_xy, PAINT_Z / 2), (*half_xy, PAINT_Z / 2), b.flat_material("paint", (0.92, 0.92, 0.88, 1)),
          yaw=yaw, tile_m=1.0, category="path")


def add_markings(b, road_half: float, main_x: tuple, cross_y: tuple) -> None:
    """Centre lines, lane dashes, parking edges, zebra crossings and the stop line."""
    e = road_half
    spans = (("x", main_x[0], -e - 6), ("x", e + 6, main_x[1]), ("y", cross_y[0], -e - 6), ("y", e + 6, cross_y[1]))
    for k, (axis, t0, t1) in enumerate(spans):
        mid, half = (t0 + t1) / 2, (t1 - t0) / 2

        def at(t, off):
            return (t, off) if axis == "x" else (-off, t)

        yaw = 0.0 if axis == "x" else np.pi / 2
        for j, off in enumerate((-0.12, 0.12, -7.0, 7.0)):
            _paint(b, f"mark/{k}/line{j}", at(mid, off), (half, 0.06), yaw)
        for j, off in enumerate((-3.5, 3.5)):
            for i, t in enumerate(np.arange(t0 + 2.0, t1 - DASH_M, DASH_PERIOD_M)):
                _paint(b, f"mark/{k}/dash{j}_{i}", at(t + DASH_M / 2, off), (DASH_M / 2, 0.06), yaw)
    for k, (axis, t) in enumerate((("x", -e - 3.5), ("x", e + 3.5), ("y", -e - 3.5), ("y", e + 3.5))):
        for i, off in enumerate(np.arange(-e + 0.75, e, 1.2)):
            c = (t, off) if axis == "x" else (off, t)
            half = (2.0, 0.3) if axis == "x" else (0.3, 2.0)
            _paint(b, f"mark/zebra{k}_{i}", c, half)
    _paint(b, "mark/stop", (-e - 6.5, -e / 2), (0.25, e / 2))


def add_furniture(b, rng, segments, road_half: float, building_line: float, curb_h: float) -> None:
    """Lamps and trees along the curb, benches and bins by the facades, four traffic lights; each lamp, bench,
    bin and signal has its own proportions (stream ``urban/furniture-shape``), as each tree has."""
    pole, dark = b.material("concrete", variant=4), b.material("concrete", variant=2)
    size = b.streams("urban/furniture-shape")
    k = 0
    for seg in segments:
        for side in (1, -1):
            for t in np.arange(seg.t0 + 8.0, seg.t1 - 4.0, 30.0):
                q = seg.point(t, side * (road_half + 0.6))
                top, arm, r = size.uniform(6.4, 7.6), size.uniform(0.45, 0.8), size.uniform(0.075, 0.11)
                b.cylinder(f"lamp{k}/pole", q, curb_h, top, r, pole, segments=8, category="furniture")
                head = seg.point(t, side * (road_half + 0.4 - arm))
                b.box(f"lamp{k}/arm", (*head, top), (arm, 0.08, 0.06), pole, yaw=seg.yaw + np.pi / 2,
                      category="furniture")
                tq = seg.point(t + 15.0 + rng.uniform(-3, 3), side * (road_half + 1.2))
                if rng.random() < 0.7 and t + 15.0 < seg.t1 - 4.0:
                    th = rng.uniform(2.5, 3.5)
                    b.cylinder(f"tree{k}/trunk", tq, curb_h, th, rng.uniform(0.14, 0.2), b.material("bark"),
                               segments=8, category="tree")
                    r = rng.uniform(1.4, 2.0)
                    b.ellipsoid(f"tree{k}/crown", (*tq, th + r * 0.8), (r, r, r * 1.2),
                                b.material("foliage", variant=int(k % 3), size=128), tile_m=1.5, n_lat=6, n_lon=10,
                                category="tree")
                u = rng.random()
                fq = seg.point(t + rng.uniform(3, 12), side * (building_line - 0.9))
                if u < 0.35:
                    hl, hh = size.uniform(0.65, 1.15), size.uniform(0.25, 0.35)
                    b.box(f"bench{k}", (*fq, curb_h + hh), (hl, size.uniform(0.2, 0.3), hh),
                          b.material("wood", variant=2), yaw=seg.yaw, category="furniture")
                elif u < 0.65:
                    b.cylinder(f"bin{k}", fq, curb_h, curb_h + size.uniform(0.8, 1.15), size.uniform(0.22, 0.36),
                               b.material("graffiti", variant=5), segments=10, category="furniture")
                k += 1
    for j, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
        q = np.array([sx, sy]) * (road_half + 0.8)
        top = size.uniform(4.2, 4.8)
        b.cylinder(f"signal{j}/pole", q, curb_h, top, 0.08, dark, segments=8, category="furniture")
        b.box(f"signal{j}/head", (*q, top - 0.4), (0.18, 0.18, size.uniform(0.4, 0.55)), dark, category="furniture")


def add_parked_cars(b, rng, segments, road_half: float) -> None:
    """Cars in seeded slots of the parking lanes (not within 25 m of the intersection), each an object of its
    own: a body type and stretch (:func:`scenes.car_shapes.draw_body`, stream ``urban/parked-shape``) as its
    own mesh ``mesh/parked/<k>``, an atlas laid out for it (:func:`scenes.actor_textures.car_layout`, same
    stream; colours from ``texture/urban-parked/<k>``) and a pose of its own in the slot (stream
    ``urban/parked-pose``: +-0.6 m along, +-0.12 m across, +-2 deg), so no two stretches of the parking lane
    repeat each other."""
    pose, shape = b.streams("urban/parked-pose"), b.streams("urban/parked-shape")
    off = road_half - 1.25
    k = 0
    for seg in segments:
        for side in (1, -1):
            for t in np.arange(seg.t0 + 4.0, seg.t1 - 4.0, PARK_SLOT_M):
                if abs(t) < 25.0 or rng.random() > 0.4:
                    continue
                q = seg.point(t + pose.uniform(-0.6, 0.6), side * (off + pose.uniform(-0.12, 0.12)))
                rng.integers(0, 6)                                   # (the former texture variant: keeps the draws)
                yaw = seg.yaw + (np.pi if side > 0 else 0.0) + pose.uniform(-0.035, 0.035)   # along its lane
                body = draw_body(shape)
                mesh = b.spec.add_mesh(name=f"mesh/parked/{k}")
                mesh.uservert, mesh.usertexcoord, mesh.userface = parts_mesh("car", body.parts(), body.wheels())
                colours = b.streams(f"texture/urban-parked/{k}")
                atlas = car_atlas(colours, car_layout(shape, body.arches()))
                mat = b.image_material(f"parked/{k}", atlas, specular=0.35)
                b.mesh_instance(f"parked{k}", f"mesh/parked/{k}", (*q, 0.0), yaw, mat, body.half_xy(),
                                (0.0, body.height()), category="car")
                k += 1
