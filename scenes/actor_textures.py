"""Texture atlases of the urban actors: cars, double-decker buses and pedestrians that look like them to a
feature tracker: painted bodies (one smooth colour, a mild vertical gradient and faint noise), dark glass with
a sky reflection, tyres with hubs, head- and tail-lights, plates, seams; clothes and skin for pedestrians.
No repetitive high-contrast pattern: the corners are where a real vehicle has them (window corners, lights,
wheels, plates).

One atlas per actor, ``(H, W, 3) uint8``, drawn from the generator the caller passes (the ``dynamic`` stream's
per-actor draw), laid out in named *cells* (:data:`LAYOUTS`: ``name -> (x0, y0, w, h)`` pixels); a mesh face
maps onto one cell (:func:`cell_uv`). Row 0 is the top of the image (MuJoCo's 2-D texture convention).
"""
from __future__ import annotations

import numpy as np

from scenes.bus_shapes import BusBody, bus_layout
from scenes.errors import SceneError
from scenes.textures import fbm

# name -> (x0, y0, w, h) in texels
LAYOUTS = {
    "car": ((256, 128), {"paint": (0, 0, 64, 64), "body_side": (64, 0, 64, 64), "front": (128, 0, 64, 64),
                         "rear": (192, 0, 64, 64), "cabin_side": (0, 64, 64, 64), "windscreen": (64, 64, 64, 64),
                         "tyre": (128, 64, 64, 64), "under": (192, 64, 64, 64)}),
    "bus": ((256, 128), {"side": (0, 0, 128, 64), "front": (128, 0, 64, 64), "rear": (192, 0, 64, 64),
                         "paint": (0, 64, 64, 64), "tyre": (64, 64, 64, 64), "under": (128, 64, 64, 64),
                         "roof": (192, 64, 64, 64)}),
    "pedestrian": ((128, 64), {"legs_front": (0, 0, 32, 32), "legs_side": (32, 0, 32, 32),
                               "torso_front": (64, 0, 32, 32), "torso_side": (96, 0, 32, 32),
                               "face": (0, 32, 32, 32), "head_side": (32, 32, 32, 32), "hair": (64, 32, 32, 32),
                               "shoulders": (96, 32, 32, 32)}),
}

# (colour, weight): a street's car colours (white, black, silver and grey dominate)
CAR_COLOURS = (((0.88, 0.88, 0.86), 0.24), ((0.07, 0.07, 0.08), 0.18), ((0.62, 0.63, 0.65), 0.16),
               ((0.38, 0.39, 0.41), 0.14), ((0.55, 0.08, 0.07), 0.08), ((0.10, 0.18, 0.42), 0.08),
               ((0.12, 0.26, 0.17), 0.04), ((0.68, 0.6, 0.46), 0.04), ((0.85, 0.68, 0.1), 0.04))
BUS_COLOURS = (((0.66, 0.07, 0.06), 0.5), ((0.9, 0.9, 0.88), 0.2), ((0.12, 0.25, 0.5), 0.15),
               ((0.1, 0.4, 0.22), 0.15))
CLOTHES = ((0.08, 0.08, 0.1), (0.15, 0.18, 0.3), (0.35, 0.3, 0.22), (0.5, 0.5, 0.52), (0.6, 0.15, 0.12),
           (0.85, 0.85, 0.82), (0.2, 0.35, 0.25), (0.55, 0.45, 0.3))
SKIN = ((0.93, 0.76, 0.65), (0.8, 0.6, 0.45), (0.6, 0.42, 0.3), (0.4, 0.27, 0.18))
HAIR = ((0.08, 0.06, 0.05), (0.3, 0.2, 0.1), (0.6, 0.5, 0.3), (0.5, 0.5, 0.5))
GLASS = np.array([0.07, 0.09, 0.11])
RUBBER = np.array([0.06, 0.06, 0.065])


def cell_uv(kind: str, cell: str, fu, fv, inset: float = 1.5) -> tuple:
    """Texture coordinates (u, v) in [0, 1] of the fractions ``fu`` (left to right) and ``fv`` (top to bottom)
    of ``cell`` of a ``kind`` atlas, ``inset`` texels inside its border (no bleeding across cells)."""
    (W, H), cells = LAYOUTS[kind]
    if cell not in cells:
        raise SceneError(f"actor atlas {kind!r}: no cell {cell!r}; cells: {', '.join(cells)}")
    x0, y0, w, h = cells[cell]
    u = (x0 + inset + np.asarray(fu, float) * (w - 2 * inset)) / W
    v = (y0 + inset + np.asarray(fv, float) * (h - 2 * inset)) / H
    return u, v


def _pick(rng, table):
    cols = np.array([c for c, _ in table], float)
    w = np.array([p for _, p in table], float)
    return np.clip(cols[rng.choice(len(cols), p=w / w.sum())] + rng.normal(0, 0.015, 3), 0, 1)


class _Atlas:
    """Drawing in fractional cell coordinates on a float image."""

    def __init__(self, kind, rng):
        (W, H), self.cells = LAYOUTS[kind]
        self.img = np.zeros((H, W, 3))
        self.rng = rng

    def _box(self, cell):
        x0, y0, w, h = self.cells[cell]
        return x0, y0, w, h

    def fill(self, cell, colour, gradient=0.0, noise=0.0):
        """Cell in ``colour`` x (1 + gradient (0.5 - row fraction)) plus faint noise of amplitude ``noise``."""
        x0, y0, w, h = self._box(cell)
        n = max(w, h)
        shade = 1.0 + gradient * (0.5 - (np.arange(h) + 0.5) / h)[:, None, None]
        grain = noise * fbm(self.rng, n, 4, 3)[:h, :w, None] if noise else 0.0
        self.img[y0:y0 + h, x0:x0 + w] = np.asarray(colour, float) * shade + grain

    def rect(self, cell, fx0, fy0, fx1, fy1, colour, gradient=0.0):
        x0, y0, w, h = self._box(cell)
        a, b = y0 + int(round(fy0 * h)), y0 + max(int(round(fy1 * h)), int(round(fy0 * h)) + 1)
        c, d = x0 + int(round(fx0 * w)), x0 + max(int(round(fx1 * w)), int(round(fx0 * w)) + 1)
        shade = 1.0 + gradient * (0.5 - (np.arange(b - a) + 0.5) / max(1, b - a))[:, None, None]
        self.img[a:b, c:d] = np.asarray(colour, float) * shade

    def glass(self, cell, fx0, fy0, fx1, fy1):
        """Dark glass with the sky's reflection: lighter at the top, one soft diagonal highlight."""
        x0, y0, w, h = self._box(cell)
        a, b = y0 + int(round(fy0 * h)), y0 + int(round(fy1 * h))
        c, d = x0 + int(round(fx0 * w)), x0 + int(round(fx1 * w))
        if b <= a or d <= c:
            return
        yy, xx = np.mgrid[0:b - a, 0:d - c] / np.array([max(1, b - a), max(1, d - c)])[:, None, None]
        refl = 0.10 * (1 - yy) + 0.07 * np.exp(-((xx - yy - self.rng.uniform(-0.3, 0.3)) / 0.25) ** 2)
        self.img[a:b, c:d] = GLASS + refl[..., None] * np.array([0.9, 1.0, 1.1])

    def disc(self, cell, fx, fy, fr, colour):
        x0, y0, w, h = self._box(cell)
        yy, xx = np.mgrid[0:h, 0:w]
        m = ((xx + 0.5) / w - fx) ** 2 + ((yy + 0.5) / h - fy) ** 2 <= fr ** 2
        sub = self.img[y0:y0 + h, x0:x0 + w]
        sub[m] = colour

    def done(self) -> np.ndarray:
        return np.clip(np.round(np.clip(self.img, 0, 1) * 255), 0, 255).astype(np.uint8)


def _tyre(at, cell, hub):
    at.fill(cell, RUBBER, noise=0.01)
    at.disc(cell, 0.5, 0.5, 0.32, hub)
    at.disc(cell, 0.5, 0.5, 0.12, hub * 0.55)


# a moving car's layout (fractions of each cell; handle: dx0, y0, dx1, y1 from its seam); a parked car draws
# its own (:func:`car_layout`)
CAR_LAYOUT = {"seams": (0.36, 0.62), "handle": (0.04, 0.22, 0.1, 0.3), "sill": 0.84, "arches": ((0.19, 0.81), 0.16),
              "headlight": (0.05, 0.12, 0.22, 0.24), "grille": (0.32, 0.2, 0.68, 0.46), "bumper": (0.66, 0.84),
              "front_plate": (0.41, 0.62, 0.59, 0.76), "taillight": (0.03, 0.14, 0.18, 0.22),
              "rear_plate": (0.4, 0.4, 0.6, 0.56), "panes": (0.1, 0.47, 0.53, 0.88), "pane_y": (0.12, 0.92),
              "screen": (0.06, 0.1, 0.94, 0.95), "trim": 0}
TRIMS = ((0.09, 0.09, 0.1), (0.5, 0.51, 0.53), (0.2, 0.2, 0.21))   # black, chrome-grey, dark grey


def car_layout(rng: np.random.Generator, arches=((0.19, 0.81), 0.16)) -> dict:
    """A parked car's own layout, :data:`CAR_LAYOUT`'s keys: 2 or 4 doors (seams), lights, grille, plates,
    window panes and trim drawn from ``rng``; ``arches``: its body's wheel arches
    (:meth:`scenes.car_shapes.CarBody.arches`)."""
    u = rng.uniform
    doors = (float(u(0.42, 0.52)),) if rng.random() < 0.3 else (float(u(0.32, 0.4)), float(u(0.58, 0.66)))
    hx, hw, hy, hh = u(0.02, 0.1), u(0.14, 0.26), u(0.08, 0.2), u(0.12, 0.3)
    tx, tw, ty, th = u(0.0, 0.08), u(0.12, 0.24), u(0.08, 0.22), u(0.12, 0.3)
    gw, gy, gh = u(0.2, 0.42), u(0.16, 0.3), u(0.12, 0.3)
    split = u(0.45, 0.6)
    dx, hy = u(0.03, 0.06), u(0.16, 0.28)
    return {"seams": doors, "handle": (dx, hy, dx + u(0.05, 0.08), hy + 0.08), "sill": u(0.8, 0.9),
            "arches": arches, "headlight": (hx, hy, hw, hh), "grille": (0.5 - gw / 2, gy, 0.5 + gw / 2, gy + gh),
            "bumper": (u(0.6, 0.7), u(0.8, 0.9)), "front_plate": (0.41, u(0.58, 0.66), 0.59, u(0.72, 0.78)),
            "taillight": (tx, ty, tw, th), "rear_plate": (0.4, u(0.34, 0.5), 0.6, u(0.5, 0.6)),
            "panes": (u(0.06, 0.16), split - 0.03, split + 0.03, u(0.84, 0.94)),
            "pane_y": (u(0.08, 0.2), u(0.86, 0.95)),
            "screen": (u(0.04, 0.1), u(0.06, 0.16), 1 - u(0.04, 0.1), u(0.9, 0.96)), "trim": int(rng.integers(0, 3))}


def car_atlas(rng: np.random.Generator, layout: dict | None = None) -> np.ndarray:
    """A car: paint on ``paint``/``body_side``/``front``/``rear``, windows on ``cabin_side``/``windscreen``;
    lights, plates, seams, windows and trim where ``layout`` puts them (None: :data:`CAR_LAYOUT`)."""
    L = CAR_LAYOUT if layout is None else layout
    at = _Atlas("car", rng)
    paint = _pick(rng, CAR_COLOURS)
    seam, trim = paint * 0.55, np.array(TRIMS[L["trim"]])
    at.fill("paint", paint, gradient=0.08, noise=0.012)
    at.fill("under", RUBBER * 1.5)
    at.fill("body_side", paint, gradient=0.15, noise=0.012)
    hdx, hy0, hdw, hy1 = L["handle"]
    for fx in L["seams"]:                                                 # door seams and handles
        at.rect("body_side", fx, 0.08, fx + 0.012, 0.8, seam)
        at.rect("body_side", fx + hdx, hy0, fx + hdw, hy1, paint * 0.7)
    at.rect("body_side", 0.0, L["sill"], 1.0, 1.0, trim)                 # sill
    arch_x, arch_r = L["arches"]
    for fx in arch_x:                                                     # wheel arches
        at.disc("body_side", fx, 1.0, arch_r, trim)
    at.fill("front", paint, gradient=0.12, noise=0.012)
    hx, hy, hw, hh = L["headlight"]
    for fx in (hx, 1.0 - hx - hw):
        at.rect("front", fx, hy, fx + hw, hy + hh, (0.93, 0.92, 0.84))   # headlights
    at.rect("front", *L["grille"], trim)                                  # grille
    at.rect("front", 0.0, L["bumper"][0], 1.0, L["bumper"][1], trim * 1.4)   # bumper
    at.rect("front", *L["front_plate"], (0.9, 0.9, 0.86))                # plate
    at.fill("rear", paint, gradient=0.12, noise=0.012)
    tx, ty, tw, th = L["taillight"]
    for fx in (tx, 1.0 - tx - tw):
        at.rect("rear", fx, ty, fx + tw, ty + th, (0.62, 0.06, 0.05))    # tail-lights
    at.rect("rear", 0.0, L["bumper"][0], 1.0, L["bumper"][1], trim * 1.4)
    at.rect("rear", *L["rear_plate"], (0.9, 0.9, 0.86))                  # plate
    at.fill("cabin_side", paint, gradient=0.1)
    (p0, p1, p2, p3), (py0, py1) = L["panes"], L["pane_y"]
    at.glass("cabin_side", p0, py0, p1, py1)
    at.glass("cabin_side", p2, py0, p3, py1)
    at.fill("windscreen", paint, gradient=0.1)
    at.glass("windscreen", *L["screen"])
    _tyre(at, "tyre", np.array([0.55, 0.56, 0.58]) + rng.normal(0, 0.03))
    return at.done()


LIVERY = ((0.9, 0.88, 0.2), (0.95, 0.95, 0.93), (0.1, 0.1, 0.12), (0.8, 0.3, 0.08), (0.25, 0.55, 0.8),
          (0.45, 0.7, 0.3), (0.6, 0.1, 0.4))                                  # stripe / skirt colours
INK = ((0.05, 0.05, 0.06), (0.95, 0.95, 0.92), (0.8, 0.1, 0.1), (0.1, 0.2, 0.6), (0.95, 0.75, 0.1))


def bus_atlas(rng: np.random.Generator, layout: dict | None = None) -> np.ndarray:
    """A bus: its livery (paint, skirt, stripes), the window bays of its decks, doors, an advert panel (a
    background, lines of text, a logo), a fleet number and wear on ``side``; windscreens, destination display
    and lights on ``front``; window, lights and plate on ``rear``, where ``layout`` puts them
    (:func:`scenes.bus_shapes.bus_layout`; None: the layout of a standard double-decker drawn from ``rng``)."""
    L = layout if layout is not None else bus_layout(rng, BusBody(2, 5.5, 1.25, 4.2, 0.5, (-3.3, 3.3)))
    at = _Atlas("bus", rng)
    paint = _pick(rng, BUS_COLOURS)
    second = np.array(LIVERY[rng.integers(0, len(LIVERY))])
    trim = np.array([0.09, 0.09, 0.1])
    at.fill("paint", paint, gradient=0.05, noise=0.012)
    at.fill("roof", paint * 0.9 + 0.05, noise=0.012)
    at.fill("under", RUBBER * 1.5)
    at.fill("side", paint, gradient=0.08, noise=0.012)
    at.rect("side", 0.0, L["skirt"], 1.0, 1.0, second * 0.6 if rng.random() < 0.5 else trim)
    for fy0, fy1 in L["stripes"]:
        at.rect("side", 0.0, fy0, 1.0, fy1, second)
    if L["advert"] is not None:
        x0, y0, x1, y1 = L["advert"]
        back = rng.uniform(0.15, 0.95, 3)
        at.rect("side", x0, y0, x1, y1, back)
        for _ in range(int(rng.integers(1, 4))):                         # lines of text, a logo
            tx, ty = rng.uniform(0.05, 0.5), rng.uniform(0.1, 0.6)
            ink = np.array(INK[rng.integers(0, len(INK))])
            at.rect("side", x0 + tx * (x1 - x0), y0 + ty * (y1 - y0), x0 + (tx + rng.uniform(0.2, 0.45)) * (x1 - x0),
                    y0 + (ty + rng.uniform(0.12, 0.3)) * (y1 - y0), ink)
        if rng.random() < 0.6:
            at.disc("side", x0 + rng.uniform(0.75, 0.9) * (x1 - x0), 0.5 * (y0 + y1), 0.3 * (y1 - y0),
                    rng.uniform(0.0, 1.0, 3))
    for fy0, fy1, windows in L["decks"]:
        for fx0, fx1 in windows:
            at.glass("side", fx0, fy0, fx1, fy1)
    for fx0, fx1 in L["doors"]:
        at.rect("side", fx0 - 0.005, L["door_y"][0] - 0.01, fx1 + 0.005, L["door_y"][1], trim)
        at.glass("side", fx0, L["door_y"][0], 0.5 * (fx0 + fx1) - 0.003, L["door_y"][1] - 0.01)
        at.glass("side", 0.5 * (fx0 + fx1) + 0.003, L["door_y"][0], fx1, L["door_y"][1] - 0.01)
    nx, ny = L["number"]
    at.rect("side", nx, ny, nx + 0.05, ny + 0.04, np.array(INK[int(paint.mean() < 0.5)]))
    (ax0, ax1), ar = L["arches"]
    for fx in (ax0, ax1):
        at.disc("side", fx, 1.0, ar, trim)
    x0, y0, w, h = at.cells["side"]                                        # wear: grime towards the bottom
    grime = np.clip(fbm(rng, w, 4, 3, aspect=0.25)[:h, :w], 0, None) * ((np.arange(h) + 0.5) / h)[:, None]
    at.img[y0:y0 + h, x0:x0 + w] *= (1.0 - L["wear"] * 2.0 * grime)[..., None]
    at.fill("front", paint, gradient=0.06, noise=0.012)
    upper, lower = L["screens"]
    if upper is not None:
        at.glass("front", 0.06, upper[0], 0.94, upper[1])
    at.glass("front", 0.06, lower[0], 0.94, lower[1])
    dx, dy = L["display"]
    at.rect("front", dx, dy, 1.0 - dx, dy + 0.06, (0.05, 0.05, 0.05))   # destination display
    at.rect("front", dx + 0.04, dy + 0.015, dx + 0.04 + rng.uniform(0.2, 0.5), dy + 0.045, (0.9, 0.6, 0.1))
    lx, lw, ly = L["lights"]
    for fx in (lx, 1.0 - lx - lw):
        at.rect("front", fx, ly, fx + lw, ly + 0.06, (0.93, 0.92, 0.84))
    at.fill("rear", paint, gradient=0.06, noise=0.012)
    rx, ry0, ry1 = L["rear_window"]
    at.glass("rear", rx, ry0, 1.0 - rx, ry1)
    tx, tw, ty = L["tail"]
    for fx in (tx, 1.0 - tx - tw):
        at.rect("rear", fx, ty, fx + tw, ty + 0.1, (0.62, 0.06, 0.05))
    at.rect("rear", 0.4, 0.84, 0.6, 0.9, (0.9, 0.9, 0.86))
    _tyre(at, "tyre", np.array([0.45, 0.45, 0.47]) + rng.normal(0, 0.03))
    return at.done()


def pedestrian_atlas(rng: np.random.Generator) -> np.ndarray:
    """A pedestrian: trousers and shoes, a top with arms, face (skin) and hair."""
    at = _Atlas("pedestrian", rng)
    cl = np.array(CLOTHES)
    trousers, top = cl[rng.integers(0, len(cl))], cl[rng.integers(0, len(cl))]
    skin, hair = np.array(SKIN[rng.integers(0, len(SKIN))]), np.array(HAIR[rng.integers(0, len(HAIR))])
    shoes = np.array([0.06, 0.06, 0.06]) if rng.random() < 0.7 else np.array([0.8, 0.8, 0.78])
    for c in ("legs_front", "legs_side"):
        at.fill(c, trousers, gradient=0.1, noise=0.015)
        at.rect(c, 0.0, 0.88, 1.0, 1.0, shoes)
    at.rect("legs_front", 0.47, 0.0, 0.53, 0.88, trousers * 0.6)          # gap between the legs
    for c in ("torso_front", "torso_side", "shoulders"):
        at.fill(c, top, gradient=0.12, noise=0.015)
    at.rect("torso_side", 0.3, 0.05, 0.7, 1.0, top * 0.85)               # the arm
    at.rect("torso_side", 0.3, 0.85, 0.7, 1.0, skin)                     # the hand
    at.rect("torso_front", 0.38, 0.0, 0.62, 0.1, skin)                   # neck
    at.fill("face", skin, gradient=0.1)
    at.rect("face", 0.0, 0.0, 1.0, 0.2, hair)
    at.rect("face", 0.25, 0.4, 0.4, 0.48, (0.15, 0.1, 0.08))             # eyes
    at.rect("face", 0.6, 0.4, 0.75, 0.48, (0.15, 0.1, 0.08))
    at.fill("head_side", skin, gradient=0.1)
    at.rect("head_side", 0.0, 0.0, 1.0, 0.3, hair)
    at.rect("head_side", 0.6, 0.0, 1.0, 0.8, hair)
    at.fill("hair", hair, noise=0.02)
    return at.done()


ATLASES = {"car": car_atlas, "bus": bus_atlas, "pedestrian": pedestrian_atlas}


def actor_atlas(kind: str, rng: np.random.Generator) -> np.ndarray:
    """The ``(H, W, 3) uint8`` atlas of one actor of ``kind`` (car, bus, pedestrian) drawn from ``rng``."""
    if kind not in ATLASES:
        raise SceneError(f"actor kind {kind!r}: no atlas; valid: {', '.join(ATLASES)}")
    if not isinstance(rng, np.random.Generator):
        raise SceneError(f"actor atlas rng: expected a numpy Generator, got {type(rng).__name__}")
    return ATLASES[kind](rng)
