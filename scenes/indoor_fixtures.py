"""What real indoor walls carry, each instance its own: doors, fire-extinguisher cabinets under their signs,
framed pictures, whiteboards, notice boards, clocks and cable trunking.

A long plain wall in a real building is still not blank over its whole length: it has a door to a store room, an
extinguisher with its sign, a picture, a whiteboard or a clock, and cable trunking along it, with plain paint
between them. Each fixture here is a thin box standing proud of the wall (so it also has depth edges), textured
with an image of its own at :data:`PX_PER_M` texels per metre mapped once over its front: a door's panels,
handle, kick plate and room sign; a cabinet's window and label; a picture's frame, mat and photo
(:func:`scenes.indoor_print.photo`); marker writing on a whiteboard; papers pinned on cork; a clock's face at its
own time.

Layout draws come from stream ``layout/fixtures/<wall>/<side>``, each fixture's image from
``texture/fixture/<wall>/<side>/<k>``: the same seed gives the same bytes, and nothing is shared between two
fixtures.
"""
from __future__ import annotations

import numpy as np

from scenes.indoor_print import _rect, photo, print_image, words
from scenes.indoor_walls import fbm_rect
from scenes.textures import _wrap_disc, with_richness

PX_PER_M = 256.0
MAX_PX = 512
# kind: (probability, half width range m, half height range m, centre height range m, half depth m)
KINDS = {
    "door": (0.18, (0.44, 0.47), (1.0, 1.03), None, 0.025),
    "extinguisher": (0.2, (0.13, 0.18), (0.28, 0.38), (0.75, 0.95), 0.1),
    "picture": (0.22, (0.2, 0.45), (0.15, 0.35), (1.45, 1.7), 0.015),
    "whiteboard": (0.14, (0.5, 0.9), (0.4, 0.55), (1.4, 1.5), 0.015),
    "notice_board": (0.14, (0.35, 0.6), (0.3, 0.45), (1.4, 1.6), 0.012),
    "clock": (0.12, (0.13, 0.17), None, (2.0, 2.3), 0.03),
}


def _shape(w_m, h_m):
    return (int(min(MAX_PX, max(16, round(2 * h_m * PX_PER_M)))), int(min(MAX_PX, max(16, round(2 * w_m * PX_PER_M)))))


def door_image(rng, H, W):
    """A door leaf: paint or wood, panels, a lever handle, a kick plate, often a room sign, sometimes a window."""
    col = rng.uniform(0.35, 0.9) * (np.asarray((1.0, 0.78, 0.55)) if rng.random() < 0.5 else rng.uniform(0.6, 1, 3))
    img = col + 0.05 * fbm_rect(rng, H, W, W / 4.0, 4)[..., None] * (1 if rng.random() < 0.5 else 0)
    m = int(W * 0.12)
    for k in range(int(rng.integers(0, 3))):                      # panels: outlined recesses
        y0 = int(H * (0.08 + 0.45 * k)) + int(rng.integers(0, 4))
        ph = int(H * rng.uniform(0.3, 0.38))
        _rect(img, y0, m, ph, W - 2 * m, col * 0.75)
        _rect(img, y0 + 2, m + 2, ph - 4, W - 2 * m - 4, col * 1.02)
    if rng.random() < 0.4:                                        # a vision panel
        gy, gh = int(H * rng.uniform(0.12, 0.2)), int(H * rng.uniform(0.2, 0.3))
        gx, gw = int(W * rng.uniform(0.25, 0.4)), int(W * rng.uniform(0.15, 0.3))
        _rect(img, gy - 2, gx - 2, gh + 4, gw + 4, (0.7, 0.7, 0.7))
        _rect(img, gy, gx, gh, gw, rng.uniform(0.1, 0.3, 3))
    hx = int(W * 0.85) if rng.random() < 0.5 else int(W * 0.08)
    hy = int(H * rng.uniform(0.5, 0.54))
    _rect(img, hy - 8, hx, 26, 7, (0.75, 0.75, 0.72))           # handle plate and lever
    _rect(img, hy, hx + (-18 if hx > W / 2 else 4), 4, 22, (0.55, 0.55, 0.55))
    _rect(img, H - int(H * rng.uniform(0.08, 0.14)), 0, H, W, rng.uniform(0.55, 0.8) * np.ones(3))
    if rng.random() < 0.8:                                        # a room sign at eye height
        sy, sx = int(H * rng.uniform(0.22, 0.3)), int(W * rng.uniform(0.2, 0.4))
        sw, sh = int(W * rng.uniform(0.3, 0.5)), int(H * rng.uniform(0.04, 0.07))
        plate = rng.uniform(0.1, 0.95, 3)
        _rect(img, sy, sx, sh, sw, plate)
        words(rng, img, sy + sh // 4, sx + 3, sx + sw - 3, max(3, sh // 2), 1.0 - plate.round(), plate, True)
    return img


def extinguisher_image(rng, H, W):
    """A cabinet (red, white or steel) with its own window (size, place), the red cylinder at its own place
    behind it, a label and stickers of its own."""
    body = (np.asarray((0.75, 0.08, 0.06)) * rng.uniform(0.8, 1.1), np.full(3, rng.uniform(0.8, 0.95)),
            np.full(3, rng.uniform(0.45, 0.65)))[int(rng.integers(0, 3))]
    img = np.ones((H, W, 3)) * body
    m = max(2, int(W * rng.uniform(0.06, 0.16)))
    wy, wh = int(H * rng.uniform(0.04, 0.3)), int(H * rng.uniform(0.35, 0.6))
    _rect(img, wy, m, wh, W - 2 * m, rng.uniform(0.12, 0.35) * np.ones(3))         # window
    cw = int(W * rng.uniform(0.25, 0.4))
    cx = int(rng.integers(m, max(m + 1, W - m - cw)))
    _rect(img, wy + int(wh * 0.15), cx, int(wh * 0.85), cw, (0.8, 0.05, 0.05))        # cylinder, its label
    _rect(img, wy + int(wh * rng.uniform(0.3, 0.6)), cx + 1, int(wh * 0.15), cw - 2, np.full(3, 0.92))
    lab = np.full(3, 0.95) if body[1] < 0.5 else np.asarray((0.75, 0.08, 0.06))
    ly = int(rng.integers(wy + wh + 2, max(wy + wh + 3, H - H // 8)))
    lh = int(H * rng.uniform(0.06, 0.12))
    _rect(img, ly, m, lh, W - 2 * m, lab)
    words(rng, img, ly + lh // 4, m + 2, W - m - 2, max(3, lh // 2), 1.0 - lab.round(), lab, True)
    for _ in range(int(rng.integers(1, 4))):                                        # inspection tags, stickers
        sh, sw = int(rng.integers(6, 16)), int(rng.integers(6, 16))
        _rect(img, rng.integers(0, H - sh), rng.integers(0, W - sw), sh, sw, rng.uniform(0.0, 1.0, 3))
    return img


def sign_image(rng, H, W):
    """A fire sign: red (or green) square, a white pictogram (an extinguisher, a flame, an arrow)."""
    col = np.asarray((0.8, 0.1, 0.08)) if rng.random() < 0.8 else np.asarray((0.05, 0.55, 0.25))
    img = np.ones((H, W, 3)) * col
    w = np.full(3, 0.97)
    _rect(img, H * 0.2, W * 0.25, H * 0.6, W * 0.18, w)                 # cylinder
    _wrap_disc(img, H * 0.2, W * 0.34, W * 0.07, w)
    _rect(img, H * 0.15, W * 0.34, H * 0.05, W * rng.uniform(0.15, 0.3), w)    # hose
    fx, fy = W * rng.uniform(0.6, 0.72), H * rng.uniform(0.35, 0.6)
    for k in range(int(rng.integers(2, 5))):                              # flames
        _wrap_disc(img, fy + k * H * 0.06, fx + rng.uniform(-0.08, 0.08) * W, W * rng.uniform(0.05, 0.1), w)
    if rng.random() < 0.5:
        _rect(img, H * 0.85, W * 0.1, max(2, H * 0.05), W * 0.8, w)
    return img


def picture_image(rng, H, W):
    """A framed picture: frame (wood, black, metal), often a mat, a photo of its own."""
    frame = rng.uniform(0.05, 0.8) * (np.asarray((1.0, 0.75, 0.5)) if rng.random() < 0.5 else np.ones(3))
    img = np.ones((H, W, 3)) * frame
    f = max(2, int(min(H, W) * rng.uniform(0.04, 0.09)))
    matw = int(min(H, W) * rng.uniform(0.06, 0.14)) if rng.random() < 0.6 else 0
    _rect(img, f, f, H - 2 * f, W - 2 * f, np.full(3, rng.uniform(0.85, 0.97)))
    i = f + matw
    img[i:H - i, i:W - i] = photo(rng, H - 2 * i, W - 2 * i)
    return img


def whiteboard_image(rng, H, W):
    """An aluminium-framed whiteboard: marker writing (lines of words, a diagram of boxes and arrows, scribbles),
    half-wiped smears, a few magnets."""
    img = np.ones((H, W, 3)) * 0.96 + 0.02 * fbm_rect(rng, H, W, W / 5.0, 3)[..., None]
    for _ in range(int(rng.integers(1, 4))):                      # smears of wiped writing
        _wrap_disc(img, rng.integers(0, H), rng.integers(0, W), rng.uniform(10, 40), (0.85, 0.87, 0.9), 0.3)
    inks = (np.asarray((0.1, 0.15, 0.6)), np.asarray((0.1, 0.1, 0.1)), np.asarray((0.7, 0.1, 0.1)),
            np.asarray((0.1, 0.5, 0.2)))
    y = int(rng.integers(8, 30))
    while y < H - 30:
        ink = inks[int(rng.integers(0, 4))]
        if rng.random() < 0.3:                                    # boxes joined by lines
            n = int(rng.integers(2, 4))
            bw, bh = int(W * rng.uniform(0.1, 0.2)), int(rng.integers(18, 40))
            xs = np.sort(rng.choice(np.arange(10, W - bw - 10), n, replace=False))
            for x in xs:
                _rect(img, y, x, bh, bw, ink)
                _rect(img, y + 2, x + 2, bh - 4, bw - 4, (0.96, 0.96, 0.96))
                words(rng, img, y + bh // 3, x + 4, x + bw - 4, max(3, bh // 4), ink, (0.96,) * 3)
            for a, c in zip(xs[:-1], xs[1:]):
                _rect(img, y + bh // 2, a + bw, 2, c - a - bw, ink)
            y += bh + int(rng.integers(10, 25))
        else:
            xh = int(rng.integers(5, 10))
            x0 = int(rng.integers(6, W // 3))
            words(rng, img, y, x0, int(x0 + (W - x0) * rng.uniform(0.4, 0.95)), xh, ink, (0.96,) * 3, True)
            y += int(xh * rng.uniform(2.2, 3.5))
    for _ in range(int(rng.integers(0, 4))):
        _wrap_disc(img, rng.integers(5, H - 5), rng.integers(5, W - 5), rng.uniform(3, 6), rng.uniform(0, 1, 3))
    b = 5
    img[:b], img[-b:], img[:, :b], img[:, -b:] = 0.7, 0.55, 0.68, 0.62
    return img


def notice_board_image(rng, H, W):
    """Cork with papers of their own pinned on it at slight offsets, coloured pins."""
    img = np.asarray((0.62, 0.45, 0.28)) * (1 + 0.15 * fbm_rect(rng, H, W, 6.0, 3)[..., None])
    img *= 1 + 0.1 * (rng.random((H, W, 1)) - 0.5)
    for _ in range(int(rng.integers(3, 9))):
        ph, pw = int(H * rng.uniform(0.25, 0.5)), int(W * rng.uniform(0.15, 0.3))
        y, x = int(rng.integers(0, H - ph)), int(rng.integers(0, W - pw))
        paper = print_image(rng, 128)
        idx_y = (np.arange(ph) * 128 // ph)
        idx_x = (np.arange(pw) * 128 // pw)
        img[y:y + ph, x:x + pw] = paper[np.ix_(idx_y, idx_x)]
        _wrap_disc(img, y + 3, x + pw // 2, 2.5, rng.uniform(0, 1, 3))
    f = 6
    frame = rng.uniform(0.2, 0.7) * np.asarray((1.0, 0.8, 0.6))
    img[:f], img[-f:], img[:, :f], img[:, -f:] = frame, frame, frame, frame
    return img


def clock_image(rng, H, W):
    """A wall clock: a rim, a white face with hour marks and its own time."""
    rim = rng.uniform(0.05, 0.8, 3)
    img = np.ones((H, W, 3)) * rim
    c, r = H / 2.0, H / 2.0 * 0.88
    _wrap_disc(img, c, c, r, (0.96, 0.96, 0.94))
    for k in range(12):
        a = k * np.pi / 6
        _wrap_disc(img, c - 0.82 * r * np.cos(a), c + 0.82 * r * np.sin(a), 2.5 if k % 3 == 0 else 1.5, (0.1,) * 3)
    for length, width, a in ((0.5, 3, rng.uniform(0, 2 * np.pi)), (0.75, 2, rng.uniform(0, 2 * np.pi))):
        for t in np.linspace(0, length * r, 40):
            _wrap_disc(img, c - t * np.cos(a), c + t * np.sin(a), width / 2, (0.05,) * 3)
    _wrap_disc(img, c, c, 3, (0.6, 0.1, 0.1))
    return img


# one per scene: a fire point's cabinet and sign follow one design in a building, so two are look-alikes
ONCE = ("extinguisher",)
DRAW = {"door": door_image, "extinguisher": extinguisher_image, "picture": picture_image,
        "whiteboard": whiteboard_image, "notice_board": notice_board_image, "clock": clock_image}


def plan_fixtures(rng, length_m: float, doors=(), per_m: float = 1 / 2.5, used=None, keep_clear=(),
                  exclude=()) -> list:
    """``[(kind, t_m, z_m, half_w_m, half_h_m, proud_m)]``: fixtures along a wall side of ``length_m`` (``t`` the
    centre along it), about ``per_m`` per metre (at least one), none overlapping another, a door gap or a
    ``keep_clear`` stretch ((a, c) m). The ``n`` fixtures are spread as things on a real wall are: the k-th in the
    k-th ``length_m / n`` of the wall where it fits there (so no long stretch is left bare by chance), elsewhere if
    not. A kind of :data:`ONCE` already in the set ``used``, or in ``exclude``, is not drawn (``used`` gains each
    kind placed)."""
    used = set() if used is None else used
    kinds = list(KINDS)
    taken = [(a - 0.15, c + 0.15) for a, c in doors] + [tuple(k) for k in keep_clear]
    out = []
    n = max(1, int(rng.poisson(per_m * length_m)))
    for i in range(n):
        p = np.array([0.0 if (k in used and k in ONCE) or k in exclude else KINDS[k][0] for k in kinds])
        kind = kinds[int(rng.choice(len(kinds), p=p / p.sum()))]
        _, wr, hr, zr, proud = KINDS[kind]
        w = rng.uniform(*wr)
        h = w if hr is None else rng.uniform(*hr)
        z = h + 0.001 if zr is None else rng.uniform(*zr)
        if kind == "extinguisher":
            z = max(z, h + 0.05)
        for j in range(20):                                       # a free stretch of wall, in its slot first
            lo, hi = (i * length_m / n, (i + 1) * length_m / n) if j < 10 else (0.0, length_m)
            lo, hi = max(lo, w + 0.1), min(hi, length_m - w - 0.1)
            t = rng.uniform(lo, hi) if hi > lo else None
            if t is not None and all(t + w + 0.1 < a or t - w - 0.1 > c for a, c in taken):
                taken.append((t - w, t + w))
                used.add(kind)
                out.append((kind, t, z, w, h, proud))
                break
    return out


def add_fixtures(b, wall: str, side: str, p0, p1, room_normal, wall_t: float, doors=(),
                 per_m: float = 1 / 2.5, used=None, keep_clear=(), exclude=()) -> int:
    """Fixtures of their own on the ``side`` of the wall ``wall`` from ``p0`` to ``p1`` (x-y, m; the room face
    ``wall_t`` / 2 from that line along the unit ``room_normal``), through the ``SceneBuilder`` ``b``.
    ``used``: the set of kinds placed so far in the scene, ``keep_clear``: stretches left free, ``exclude``: kinds
    not placed (:func:`plan_fixtures`).
    Returns how many were placed."""
    p0, p1, n = np.asarray(p0, float), np.asarray(p1, float), np.asarray(room_normal, float)
    L = float(np.linalg.norm(p1 - p0))
    u = (p1 - p0) / L
    yaw = float(np.arctan2(u[1], u[0]))
    plan = plan_fixtures(b.streams(f"layout/fixtures/{wall}/{side}"), L, doors, per_m, used, keep_clear, exclude)
    for k, (kind, t, z, w, h, proud) in enumerate(plan):
        part = f"fixture/{wall}/{side}/{k}"
        key = f"texture/{part}"
        H, W = _shape(w, h)
        img = b.textures.get((b.streams(key),), ("fixture", kind, b.richness, H, W),
                             lambda: with_richness(DRAW[kind](b.streams(key), H, W), b.richness))
        mat = b.image_material(part, img, specular=0.1, shininess=0.2)
        c = p0 + u * t + n * (wall_t / 2 + proud)
        b.box(part, (*c, z), (w, proud, h), mat, yaw=yaw, tile_m=(2 * w, 2 * h), uv_off=(w, h), category="decor")
        if kind == "extinguisher":                                # its sign above it
            s = 0.1 + 0.03 * float(b.streams(key).random())
            sk = key + "/sign"
            Hs, Ws = _shape(s, s)
            simg = b.textures.get((b.streams(sk),), ("fixture", "sign", b.richness, Hs, Ws),
                                  lambda: with_richness(sign_image(b.streams(sk), Hs, Ws), b.richness))
            smat = b.image_material(part + "/sign", simg, specular=0.1, shininess=0.2)
            cs = p0 + u * t + n * (wall_t / 2 + 0.003)
            b.box(part + "/sign", (*cs, z + h + 0.25 + s), (s, 0.003, s), smat, yaw=yaw, tile_m=(2 * s, 2 * s),
                  uv_off=(s, s), category="decor")
    return len(plan)
