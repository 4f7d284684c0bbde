"""Indoor walls whose every visible side has a texture of its own, drawn at the side's full extent.

A wall side is textured by one image that covers it exactly once (no repeat within the surface): ``u`` runs
along the wall over its whole length, ``v`` from the floor to the ceiling, at :data:`PX_PER_M` texels per metre
(the 256 texels per 3 m of the scene's other wall textures). So nothing on a wall (a crack, a stain, a socket)
appears twice, and two sides never share a pattern. What a side carries is what real indoor walls have, and
they are mostly plain: paint with a faint shade variation (plaster: blotches, hairline cracks and speckle at the
density of :func:`scenes.textures.make_texture`'s plaster), board seams, a skirting board, scuffs above it, light
switches and room plates beside the doors, notices and signs, sockets, nail holes and the faint outline of
something that hung there.

Styles: ``"plaster"`` (its detail at the scene's ``richness``) and ``"white"`` (the texture-poor near-white walls:
paint detail at a fixed low contrast (0.3, as ``SceneBuilder.poor_material``), fittings at ``richness``).

Every draw comes from the stream ``texture/wall/<wall>/<side>`` (side ``left``: the side to the left of
``p0 -> p1``); a generator in the same state gives the same bytes. Texture row 0 is the ceiling.
"""
from __future__ import annotations

import numpy as np

from scenes.errors import SceneError
from scenes.textures import _cracks, _speckle, _wrap_disc, _wrap_rect

PX_PER_M = 256 / 3.0
STYLES = ("plaster", "white")
PAINTS = ((0.86, 0.84, 0.78), (0.84, 0.82, 0.74), (0.82, 0.8, 0.76), (0.8, 0.83, 0.82), (0.85, 0.82, 0.8))
POOR_CONTRAST = 0.3


def value_noise(rng: np.random.Generator, h: int, w: int, cell_px: float) -> np.ndarray:
    """(h, w) smooth value noise in [0, 1] on a random lattice of ``cell_px`` texels (not periodic)."""
    cy, cx = int(np.ceil(h / cell_px)) + 1, int(np.ceil(w / cell_px)) + 1
    grid = rng.random((cy + 1, cx + 1))

    def weights(n):
        u = np.arange(n) / cell_px
        i0 = np.floor(u).astype(int)
        f = u - i0
        return i0, i0 + 1, f * f * (3.0 - 2.0 * f)

    r0, r1, sr = weights(h)
    c0, c1, sc = weights(w)
    rows = grid[r0] * (1 - sr)[:, None] + grid[r1] * sr[:, None]
    return rows[:, c0] * (1 - sc)[None, :] + rows[:, c1] * sc[None, :]


def fbm_rect(rng: np.random.Generator, h: int, w: int, cell_px: float, octaves: int = 5,
             gain: float = 0.55) -> np.ndarray:
    """(h, w) fractal noise, zero mean, roughly in [-1, 1], coarsest cell ``cell_px`` texels."""
    out, amp, norm = np.zeros((h, w)), 1.0, 0.0
    for o in range(octaves):
        out += amp * 2.0 * (value_noise(rng, h, w, max(1.0, cell_px / 2 ** o)) - 0.5)
        norm += amp
        amp *= gain
    return out / norm


def _row(z_m: float, height_m: float) -> int:
    return int(round((height_m - z_m) * PX_PER_M))


def _plate(img, mask, y, x, h, w, col, detail):
    """A small plastic plate (switch, socket, room plate) with a shadow line and its ``detail`` callable."""
    _wrap_rect(img, y + 1, x + 1, h, w, col * 0.55, 0.6)                       # shadow below / right
    _wrap_rect(img, y, x, h, w, col)
    detail(y, x, h, w)
    mask[y:y + h + 2, x:x + w + 2] = True


def _fittings(rng, img, mask, length_m, height_m, doors, skirting_col):
    """Skirting, switches, plates and sockets on ``img`` (H, W, 3) float; ``mask`` marks what they cover."""
    H, W = img.shape[:2]
    k = int(round(rng.uniform(0.07, 0.12) * PX_PER_M))                         # skirting board
    img[H - k:] = skirting_col * (1.0 + 0.03 * rng.standard_normal((k, 1, 1)))
    img[H - k] *= 0.7
    mask[H - k - 1:] = True
    plate = np.clip(np.asarray((0.93, 0.92, 0.88)) * rng.uniform(0.92, 1.05), 0, 1)
    s = int(0.08 * PX_PER_M)

    def rocker(y, x, h, w):
        _wrap_rect(img, y + h // 4, x + w // 3, h // 2, w // 3, plate * 0.82)

    def holes(y, x, h, w):
        for dx in (w // 3, 2 * w // 3):
            _wrap_rect(img, y + h // 2 - 1, x + dx - 1, 2, 1, (0.15, 0.15, 0.15))

    def glyphs(y, x, h, w):
        for j in range(int(rng.integers(2, 5))):
            _wrap_rect(img, y + h // 3, x + 2 + 4 * j, h // 3, 3, rng.uniform(0.05, 0.3, 3))

    for a, c in doors:                                                         # beside each door: a switch
        side = rng.integers(0, 2)
        t = (a - rng.uniform(0.15, 0.3) - 0.08) if side == 0 else (c + rng.uniform(0.15, 0.3))
        if 0.1 < t < length_m - 0.2 and rng.random() < 0.85:
            _plate(img, mask, _row(rng.uniform(1.05, 1.2), height_m), int(t * PX_PER_M), s, s, plate, rocker)
        t = (c + rng.uniform(0.1, 0.3)) if side == 0 else (a - rng.uniform(0.1, 0.3) - 0.15)
        if 0.1 < t < length_m - 0.3 and rng.random() < 0.6:                    # and a room plate
            col = np.clip(rng.uniform(0.3, 0.95, 3), 0, 1)
            _plate(img, mask, _row(rng.uniform(1.45, 1.6), height_m), int(t * PX_PER_M), s, int(1.8 * s), col,
                   glyphs)
    for _ in range(rng.poisson(length_m / 2.5)):                               # notices, signs, a thermostat
        h, w = (np.array([0.3, 0.21]) * rng.uniform(0.4, 1.4)).clip(0.06) * PX_PER_M
        if rng.random() < 0.5:
            h, w = w, h
        paper = np.clip(rng.uniform(0.85, 0.97) + rng.normal(0.0, 0.03, 3), 0, 1)
        if rng.random() < 0.25:
            paper = np.clip(rng.uniform(0.1, 0.9, 3), 0, 1)                    # a coloured sign

        def text(y, x, hh, ww, ink=rng.uniform(0.0, 0.35, 3)):
            for r in range(2, hh - 3, int(rng.integers(3, 6))):
                x0 = x + 2 + int(rng.integers(0, 3))
                _wrap_rect(img, y + r, x0, 1 + (r == 2), int(rng.uniform(0.3, 0.95) * (ww - 5)), ink)

        _plate(img, mask, _row(rng.uniform(1.3, 1.9), height_m), int(rng.uniform(0, length_m) * PX_PER_M),
               int(h), int(w), paper, text)
    for _ in range(rng.poisson(length_m / 3.0)):                               # sockets, single or double
        t = rng.uniform(0.2, length_m - 0.4)
        if any(a - 0.3 < t < c + 0.1 for a, c in doors):
            continue
        _plate(img, mask, _row(rng.uniform(0.25, 0.4), height_m), int(t * PX_PER_M), s,
               s * int(rng.integers(1, 3)), plate, holes)


def _wear(rng, img, length_m, height_m):
    """Seams, scuffs above the skirting, nail holes, a faint outline where something hung, a few stains."""
    H, W = img.shape[:2]
    t = rng.uniform(0.3, 1.2)
    while t < length_m:                                                        # board seams (faint)
        _wrap_rect(img, 0, int(t * PX_PER_M), H, 1, img[H // 2, int(t * PX_PER_M) % W] * 0.96)
        t += rng.uniform(1.1, 1.3)
    mean = img[: H // 2].reshape(-1, 3).mean(axis=0)
    for _ in range(rng.poisson(1.5 * length_m)):                               # scuffs
        y, x = _row(rng.uniform(0.12, 0.9), height_m), rng.integers(0, W)
        _wrap_rect(img, y, x, rng.integers(1, 3), rng.integers(4, 30), mean * rng.uniform(0.4, 0.75), 0.5)
    for _ in range(rng.poisson(0.8 * length_m)):                               # nail holes, small marks
        _wrap_disc(img, _row(rng.uniform(1.2, 2.2), height_m), rng.integers(0, W), rng.uniform(0.5, 1.3),
                   mean * 0.4, 0.8)
    for _ in range(rng.poisson(length_m / 6.0)):                               # where a frame hung
        h, w = (rng.uniform(0.3, 0.8, 2) * PX_PER_M).astype(int)
        y, x = _row(rng.uniform(1.6, 2.1), height_m), rng.integers(0, W)
        _wrap_rect(img, y, x, h, w, mean * rng.uniform(1.02, 1.06), 0.7)
    for _ in range(rng.poisson(length_m / 4.0)):                               # stains
        _wrap_disc(img, rng.integers(0, H), rng.integers(0, W), rng.uniform(3, 12), mean * rng.uniform(0.8, 0.93), 0.4)


def wall_texture(rng: np.random.Generator, length_m: float, height_m: float, style: str, richness: float,
                 doors=()) -> np.ndarray:
    """The ``(round(height_m * PX_PER_M), round(length_m * PX_PER_M), 3) uint8`` texture of one wall side;
    ``doors``: ``(a, c)`` gaps in metres along ``u``. Detail is blended around the mean colour as
    :func:`scenes.textures.make_texture` does (``richness`` 0: one flat colour)."""
    if style not in STYLES:
        raise SceneError(f"wall style {style!r} unknown; valid: {', '.join(STYLES)}")
    if not 0.0 <= float(richness) <= 1.0:
        raise SceneError(f"wall texture richness: must be in [0, 1], got {richness!r}")
    if not (length_m > 0 and height_m > 0):
        raise SceneError(f"wall texture: length and height must be positive, got {length_m}, {height_m}")
    H, W = max(8, int(round(height_m * PX_PER_M))), max(8, int(round(length_m * PX_PER_M)))
    base = np.asarray(PAINTS[int(rng.integers(0, len(PAINTS)))]) * rng.uniform(0.95, 1.05)
    if style == "white":
        base = np.full(3, 0.91) + rng.normal(0.0, 0.01, 3)
    img = base + 0.12 * fbm_rect(rng, H, W, 0.75 * PX_PER_M, 6)[..., None]
    area = length_m * height_m / 9.0                                           # per 3 m x 3 m, as make_texture's
    for _ in range(rng.poisson(32 * area)):                                    # blotches
        _wrap_disc(img, rng.integers(0, H), rng.integers(0, W), rng.uniform(1, 5), base * rng.uniform(0.6, 0.72), 0.5)
    _cracks(rng, img, rng.poisson(4 * area), 256 // 3, base * 0.48)
    _speckle(rng, img, 0.06, 0.1)
    _wear(rng, img, length_m, height_m)
    paint_mean = img.reshape(-1, 3).mean(axis=0)
    mask = np.zeros((H, W), bool)
    skirting = np.asarray((0.9, 0.9, 0.88)) if rng.random() < 0.5 else np.asarray((0.45, 0.32, 0.2))
    _fittings(rng, img, mask, length_m, height_m, doors, skirting * rng.uniform(0.85, 1.05))
    img = np.clip(img, 0.0, 1.0)
    c_paint = POOR_CONTRAST if style == "white" else float(richness)
    out = paint_mean + np.where(mask[..., None], float(richness), c_paint) * (img - paint_mean)
    return np.clip(np.round(out * 255.0), 0, 255).astype(np.uint8)


def add_wall(b, name: str, p0, p1, sides: dict, height_m: float, thickness_m: float, door_h_m: float,
             frame_material: str, doors=()) -> None:
    """A wall of ``thickness_m`` from ``p0`` to ``p1`` (x-y, m) through the ``SceneBuilder`` ``b``, with door gaps
    ``doors`` ((a, c) m along it: a lintel above ``door_h_m``, frames of ``frame_material`` at the edges).
    ``sides``: ``{"left": style, "right": style}`` (left of ``p0 -> p1``); a side left out is never seen (an
    outer wall's outside) and gets a flat colour. Each side is a box of half the thickness whose room face
    carries its own :func:`wall_texture` (stream ``texture/<name>/<side>``), mapped once over the whole side:
    segments and lintels show their own part of it."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    L = float(np.linalg.norm(p1 - p0))
    u = (p1 - p0) / L
    n = np.array([-u[1], u[0]])
    yaw = float(np.arctan2(u[1], u[0]))
    cuts = [0.0] + [t for d in doors for t in d] + [L]
    pieces = [(a, c, 0.0, height_m) for a, c in zip(cuts[0::2], cuts[1::2]) if c - a > 1e-6]
    pieces += [(a, c, door_h_m, height_m) for a, c in doors]
    q = thickness_m / 4
    for side, sgn in (("left", 1.0), ("right", -1.0)):
        style = sides.get(side)
        if style is None:
            mat = b.flat_material("wall_outside", (0.8, 0.8, 0.78, 1))
        else:
            gaps = tuple(doors) if sgn > 0 else tuple((L - c, L - a) for a, c in reversed(doors))
            key = f"texture/{name}/{side}"
            img = b.textures.get((b.streams(key),), ("wall", style, b.richness, round(L, 6), height_m, gaps),
                                 lambda: wall_texture(b.streams(key), L, height_m, style, b.richness, gaps))
            mat = b.image_material(f"{name}/{side}", img, specular=0.05, shininess=0.1)
        for k, (a, c, z0, z1) in enumerate(pieces):
            s_c, z_c = 0.5 * (a + c), 0.5 * (z0 + z1)
            ctr = p0 + u * s_c + sgn * q * n
            b.box(f"{name}/{side}{k}", (*ctr, z_c), ((c - a) / 2, q, (z1 - z0) / 2), mat, yaw=yaw,
                  tile_m=(L, height_m), uv_off=(s_c if sgn > 0 else L - s_c, z_c), category="wall")
    for k, (a, c) in enumerate(doors):
        for j, t in enumerate((a, c)):
            ctr = p0 + u * t
            b.box(f"{name}/frame{k}_{j}", (*ctr, door_h_m / 2), (0.04, thickness_m / 2 + 0.02, door_h_m / 2),
                  frame_material, yaw=yaw, tile_m=1.0, category="wall")
