"""Bodies and liveries of the urban scene's buses, each bus an instance of its own.

A bus is a double-decker or a single-decker (:data:`DECKS`), its box proportioned by its own seeded length,
width and height and its wheels placed under it (:func:`draw_bus_body`); its atlas layout
(:func:`bus_layout`, drawn by :func:`scenes.actor_textures.bus_atlas`) gives it its own window bays (each
deck its own number of windows of unequal widths and its own pillar width), doors, livery (stripes, skirt),
an advert panel, a fleet number, front and rear details and wear. Two buses that stand at the same pose in
two views therefore do not show the same 3-D arrangement of window corners: with one window grid per bus
shape, a loop closure's rigid-motion check matched two buses 360 m apart (``vo-testbed validate places``).

The box keeps inside the footprint of :data:`scenes.urban_actors.BUS_PARTS` (half 5.5 m x 1.25 m), which
the traffic's clearance checks use: a bus only gets shorter or narrower than it. Atlas fractions: ``fu``
along the side from the rear (0) to the front (1), ``fv`` from the top (0) to the bottom (1) of the box.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.errors import SceneError

BUS_HALF_XY = (5.5, 1.25)           # the largest bus's half length and half width (the clearance footprint)
FLOOR_Z = 0.2                       # the box's underside above the ground (m)
# decks -> (probability, half length range (m), box height range (m)); about the size of the one bus shape they
# replace (11 m x 4.2 m sides: 4 % less area on average), so the traffic keeps its share of the image
DECKS = {2: (0.85, (5.2, 5.5), (4.1, 4.5)), 1: (0.15, (5.2, 5.5), (3.0, 3.3))}
BUS_CELLS = ("front", "rear", "side", "side", "roof", "under")


@dataclass(frozen=True)
class BusBody:
    """One bus's geometry: ``decks`` (1 or 2), box half length/width and height (m), wheel radius and the
    x of its rear and front axles (m, car frame: x forward)."""

    decks: int
    half_length: float
    half_width: float
    height: float
    wheel_radius: float
    axles_x: tuple

    def __post_init__(self):
        if self.decks not in DECKS:
            raise SceneError(f"bus decks: 1 or 2, got {self.decks}")
        if self.half_length > BUS_HALF_XY[0] + 1e-9 or self.half_width > BUS_HALF_XY[1] + 1e-9:
            raise SceneError(f"bus body {2 * self.half_length:.2f} x {2 * self.half_width:.2f} m exceeds the "
                             f"clearance footprint {2 * BUS_HALF_XY[0]} x {2 * BUS_HALF_XY[1]} m")

    def parts(self) -> tuple:
        """``(body,)`` as :data:`scenes.urban_actors.BUS_PARTS`."""
        h = self.height / 2
        return (("body", (self.half_length, self.half_width, h), (0.0, 0.0, FLOOR_Z + h), BUS_CELLS),)

    def wheels(self) -> tuple:
        """``(radius, half width, 4 centres)`` under the box."""
        r, y = self.wheel_radius, self.half_width - 0.1
        return r, 0.15, tuple((x, yy, r) for x in self.axles_x for yy in (-y, y))

    def arches(self) -> tuple:
        """Wheel-arch centres as fractions of the side (rear to front) and radius as a fraction of its height."""
        fx = tuple(0.5 + x / (2.0 * self.half_length) for x in self.axles_x)
        return fx, (self.wheel_radius + 0.08) / self.height


def draw_bus_body(rng: np.random.Generator) -> BusBody:
    """Decks (:data:`DECKS`' probabilities), length, width, height, wheel size and axle positions."""
    p2 = DECKS[2][0]
    decks = 2 if rng.random() < p2 else 1
    _, (l0, l1), (h0, h1) = DECKS[decks]
    half_length = float(rng.uniform(l0, l1))
    half_width = float(BUS_HALF_XY[1] * rng.uniform(0.96, 1.0))
    front = half_length - float(rng.uniform(1.6, 2.4))                 # front overhang 1.6-2.4 m
    rear = -half_length + float(rng.uniform(1.9, 3.1))
    return BusBody(decks, half_length, half_width, float(rng.uniform(h0, h1)), float(rng.uniform(0.46, 0.54)),
                   (rear, front))


def _bays(rng, a: float, b: float, n: int, pillar: float) -> tuple:
    """``n`` windows of unequal widths (0.6-1.4 of the mean) filling ``[a, b]`` between pillars of ``pillar``."""
    w = rng.uniform(0.6, 1.4, n)
    edges = a + np.concatenate([[0.0], np.cumsum(w)]) / w.sum() * (b - a)
    return tuple((float(x0 + pillar / 2), float(x1 - pillar / 2)) for x0, x1 in zip(edges[:-1], edges[1:]))


def bus_layout(rng: np.random.Generator, body: BusBody) -> dict:
    """One bus's atlas layout (fractions of its cells): ``decks`` of ``(fy0, fy1, windows)``, ``doors``
    (fx0, fx1) on the lower deck, ``stripes`` (fy0, fy1), ``skirt`` (fy0), ``advert`` (fx0, fy0, fx1, fy1) or
    None, ``number`` (fx0, fy0), ``arches``, front (``screens``, ``display``, ``lights``) and rear
    (``rear_window``, ``tail``), ``wear`` (grime strength)."""
    u = rng.uniform
    pillar = float(u(0.008, 0.03))
    door_w = float(u(0.08, 0.11))
    front_door = float(u(0.84, 0.9))
    doors = [(front_door, front_door + door_w)]
    if rng.random() < 0.6:                                              # a middle door
        mid = float(u(0.38, 0.55))
        doors.append((mid, mid + door_w))
    doors.sort()
    if body.decks == 2:
        top = (float(u(0.07, 0.13)), float(u(0.3, 0.36)))
        low = (float(u(0.45, 0.5)), float(u(0.68, 0.74)))
        upper = _bays(rng, float(u(0.02, 0.06)), float(u(0.95, 0.985)), int(rng.integers(5, 10)), pillar)
        decks = [(*top, upper)]
    else:
        low = (float(u(0.1, 0.18)), float(u(0.5, 0.6)))
        decks = []
    lower, x = [], float(u(0.02, 0.06))                                 # lower deck: windows between the doors
    for d0, d1 in doors + [(0.985, 1.0)]:
        if d0 - x > 0.06:
            lower += _bays(rng, x, d0 - 0.01, max(1, int(round((d0 - x) / u(0.1, 0.18)))), pillar)
        x = d1 + 0.01
    decks.append((*low, tuple(lower)))
    stripes = tuple((float(y), float(y + u(0.015, 0.05))) for y in
                    np.sort(u(decks[0][1], 0.86, int(rng.integers(0, 3)))))
    advert = None
    if rng.random() < 0.7:                                              # between the decks / below the windows
        w = float(u(0.25, 0.5))
        x0 = float(u(0.06, 0.8 - w))
        y0, y1 = (top[1] + 0.03, low[0] - 0.03) if body.decks == 2 else (low[1] + 0.04, low[1] + u(0.18, 0.26))
        advert = (x0, float(y0), x0 + w, float(y1))
    arch_x, arch_r = body.arches()
    return {"decks": tuple(decks), "doors": tuple(doors), "door_y": (low[0], 0.93), "stripes": stripes,
            "skirt": float(u(0.86, 0.92)), "advert": advert,
            "number": (float(u(0.7, 0.82)), float(u(0.76, 0.84))), "arches": (arch_x, arch_r),
            "screens": ((float(u(0.06, 0.14)), float(u(0.26, 0.34))) if body.decks == 2 else None,
                        (float(u(0.42, 0.5)) if body.decks == 2 else float(u(0.1, 0.2)), float(u(0.72, 0.8)))),
            "display": (float(u(0.08, 0.2)), float(u(0.34, 0.4)) if body.decks == 2 else float(u(0.02, 0.06))),
            "lights": (float(u(0.04, 0.1)), float(u(0.1, 0.16)), float(u(0.82, 0.88))),
            "rear_window": (float(u(0.1, 0.3)), float(u(0.08, 0.14)), float(u(0.26, 0.36))),
            "tail": (float(u(0.03, 0.08)), float(u(0.08, 0.14)), float(u(0.74, 0.82))),
            "wear": float(u(0.04, 0.16))}
