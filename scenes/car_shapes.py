"""Body shapes of the urban scene's cars, each car an instance of its own.

A parked car is one of :data:`BODIES` (sedan, hatchback, estate, coupe, SUV, van: a body box, a cabin box
placed and proportioned as that type's, and four wheels), stretched by its own seeded factors in length,
width and height (:func:`draw_body`), and painted with an atlas of its own whose lights, plate, seams,
windows and trim are laid out for it (:func:`scenes.actor_textures.car_layout`). So no two parked cars are
the same object: two stretches of a street do not look alike because the same car stands at the same place
in both views (the look-alike places `vo-testbed validate places` finds). The traffic's cars draw theirs
the same way, fitted into the footprint of :data:`scenes.urban_actors.CAR_PARTS` (:meth:`CarBody.fitted`),
which the clearance checks use.

Parts use the layout of :data:`scenes.urban_actors.CAR_PARTS`: ``(name, half size (3,), centre (3,), atlas cell
per face +x, -x, +y, -y, +z, -z)`` in the car frame (x forward, z up, origin on the ground); wheels are
``(radius, half width, centres)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BODY_CELLS = ("front", "rear", "body_side", "body_side", "paint", "under")
CABIN_CELLS = ("windscreen", "windscreen", "cabin_side", "cabin_side", "paint", "under")

# type -> (body half size, body centre z, cabin half size, cabin centre x, cabin centre z, wheel radius, wheel x)
BODIES = {
    "sedan": ((2.25, 0.9, 0.33), 0.63, (1.05, 0.8, 0.3), -0.15, 1.26, 0.32, 1.38),
    "hatchback": ((1.95, 0.86, 0.36), 0.66, (1.2, 0.8, 0.32), -0.55, 1.34, 0.31, 1.2),
    "estate": ((2.35, 0.9, 0.34), 0.64, (1.6, 0.8, 0.3), -0.6, 1.28, 0.32, 1.45),
    "coupe": ((2.2, 0.9, 0.3), 0.58, (0.85, 0.78, 0.25), -0.3, 1.13, 0.32, 1.35),
    "suv": ((2.3, 0.96, 0.46), 0.84, (1.45, 0.88, 0.36), -0.4, 1.66, 0.38, 1.4),
    "van": ((2.45, 0.98, 0.5), 0.82, (1.95, 0.94, 0.5), -0.4, 1.82, 0.34, 1.55),
}
STRETCH = ((0.94, 1.06), (0.96, 1.04), (0.95, 1.05))     # per-instance length, width, height factors


@dataclass(frozen=True)
class CarBody:
    """One parked car's geometry: ``kind`` of :data:`BODIES` times ``stretch`` (length, width, height)."""

    kind: str
    stretch: tuple

    def parts(self) -> tuple:
        """``(body, cabin)`` parts as :data:`scenes.urban_actors.CAR_PARTS`, stretched."""
        body, bz, cabin, cx, cz, _, _ = BODIES[self.kind]
        s = np.asarray(self.stretch, float)
        return (("body", tuple(np.asarray(body) * s), (0.0, 0.0, bz * s[2]), BODY_CELLS),
                ("cabin", tuple(np.asarray(cabin) * s), (cx * s[0], 0.0, cz * s[2]), CABIN_CELLS))

    def wheels(self) -> tuple:
        """``(radius, half width, 4 centres)``, the wheels under the stretched body."""
        body, _, _, _, _, r, wx = BODIES[self.kind]
        s = self.stretch
        r = r * min(s[0], s[2])
        y = (body[1] - 0.1) * s[1]
        return r, 0.12, tuple((x, yy, r) for x in (-wx * s[0], wx * s[0]) for yy in (-y, y))

    def fitted(self, half_xy) -> "CarBody":
        """This body shrunk (length and width only) to fit inside the footprint ``half_xy`` (m): a moving car's
        body stays inside the footprint the traffic's clearance checks use."""
        body = BODIES[self.kind][0]
        s = self.stretch
        return CarBody(self.kind, (min(s[0], half_xy[0] / body[0]), min(s[1], half_xy[1] / body[1]), s[2]))

    def half_xy(self) -> tuple:
        """The footprint: the body's half length and half width (m)."""
        body = BODIES[self.kind][0]
        return body[0] * self.stretch[0], body[1] * self.stretch[1]

    def height(self) -> float:
        """Top of the cabin above the ground (m)."""
        _, _, cabin, _, cz, _, _ = BODIES[self.kind]
        return (cz + cabin[2]) * self.stretch[2]

    def arches(self) -> tuple:
        """Wheel-arch centres as fractions of the body side's length (rear to front as the atlas cell runs)
        and the arch radius as a fraction of the body's height."""
        body, _, _, _, _, r, wx = BODIES[self.kind]
        f = wx / (2.0 * body[0])
        return (0.5 - f, 0.5 + f), min(0.3, r / (2.0 * body[2]) * 0.5)


def draw_body(rng: np.random.Generator) -> CarBody:
    """A body type (uniform over :data:`BODIES`) and its stretch factors (uniform in :data:`STRETCH`)."""
    kind = list(BODIES)[int(rng.integers(0, len(BODIES)))]
    return CarBody(kind, tuple(float(rng.uniform(a, b)) for a, b in STRETCH))
