"""Procedural RGB textures (numpy only), tileable, as ``(H, W, 3) uint8`` arrays, drawn from a
generator the caller passes in (the simulator's ``scene`` stream, key ``texture/<kind>/<variant>``).

Every generator draws a full-contrast image ``full`` in [0, 1]; :func:`make_texture` then blends it
towards its own mean colour: ``out = mean + richness * (full - mean)``.  So ``richness = 0`` gives
one flat colour (no texture at all) and ``richness = 1`` the full, corner-dense pattern.

Patterns are tileable (all stamps wrap around the borders; noise uses periodic lattices) because
MuJoCo repeats a texture across a surface; none is purely periodic over short distances (per-tile
colour jitter, cracks, speckle), so stereo matching does not lock onto a wrong period.

Texture row 0 is the top of the image (MuJoCo's 2-D texture convention, ``v`` down).
"""
from __future__ import annotations

import numpy as np

from scenes.errors import SceneError


# ---------------------------------------------------------------------------- primitives
def periodic_noise(rng: np.random.Generator, size: int, cells_yx) -> np.ndarray:
    """Tileable value noise in [0, 1], shape (size, size), ``cells_yx=(cy, cx)`` lattice cells.

    Separable smoothstep interpolation of a random periodic lattice.
    """
    cy, cx = int(cells_yx[0]), int(cells_yx[1])
    grid = rng.random((cy, cx))

    def weights(cells):
        u = np.arange(size) * cells / size
        i0 = np.floor(u).astype(int)
        f = u - i0
        s = f * f * (3.0 - 2.0 * f)
        return i0 % cells, (i0 + 1) % cells, s

    r0, r1, sr = weights(cy)
    c0, c1, sc = weights(cx)
    rows = grid[r0] * (1 - sr)[:, None] + grid[r1] * sr[:, None]          # (size, cx)
    return rows[:, c0] * (1 - sc)[None, :] + rows[:, c1] * sc[None, :]     # (size, size)


def fbm(rng: np.random.Generator, size: int, base_cells: int = 4, octaves: int = 5,
        gain: float = 0.55, aspect: float = 1.0) -> np.ndarray:
    """Tileable fractal noise, zero mean, roughly in [-1, 1]; ``aspect`` > 1 stretches along y."""
    out = np.zeros((size, size))
    amp, norm = 1.0, 0.0
    for o in range(octaves):
        cx = min(size, base_cells * 2 ** o)
        cy = max(1, min(size, int(round(cx / aspect))))
        out += amp * (periodic_noise(rng, size, (cy, cx)) - 0.5) * 2.0
        norm += amp
        amp *= gain
    return out / norm


def _wrap_rect(img, y0, x0, h, w, color, alpha=1.0):
    """Fill an h x w rectangle at (y0, x0) with wrap-around; ``img`` (H, W, 3) float."""
    H, W = img.shape[:2]
    ys = np.arange(int(y0), int(y0) + max(1, int(h))) % H
    xs = np.arange(int(x0), int(x0) + max(1, int(w))) % W
    block = img[np.ix_(ys, xs)]
    img[np.ix_(ys, xs)] = (1 - alpha) * block + alpha * np.asarray(color, float)


def _wrap_disc(img, cy, cx, r, color, alpha=1.0):
    """Fill a disc of radius r (texels) centred at (cy, cx) with wrap-around."""
    H, W = img.shape[:2]
    ri = int(np.ceil(r))
    dy, dx = np.mgrid[-ri:ri + 1, -ri:ri + 1]
    m = dy ** 2 + dx ** 2 <= r * r
    ys = (int(cy) + dy[m]) % H
    xs = (int(cx) + dx[m]) % W
    img[ys, xs] = (1 - alpha) * img[ys, xs] + alpha * np.asarray(color, float)


def _speckle(rng, img, density, amp):
    """Per-texel grey speckle: fraction ``density`` of texels shifted by +-amp."""
    H, W = img.shape[:2]
    m = rng.random((H, W)) < density
    img[m] += (rng.choice([-1.0, 1.0], size=m.sum()) * amp * rng.uniform(0.5, 1.0, m.sum()))[:, None]


def _cracks(rng, img, n, length, color, width=1):
    """Random-walk cracks (wrap-around), ``length`` steps each."""
    H, W = img.shape[:2]
    for _ in range(n):
        y, x = rng.uniform(0, H), rng.uniform(0, W)
        ang = rng.uniform(0, 2 * np.pi)
        for _ in range(int(length)):
            ang += rng.normal(0, 0.35)
            y += np.sin(ang)
            x += np.cos(ang)
            _wrap_rect(img, y, x, width, width, color, 0.8)


def _jitter(rng, base, amount):
    return np.clip(np.asarray(base, float) + rng.normal(0, amount, 3), 0, 1)


# ---------------------------------------------------------------------------- generators
def _noise_tex(rng, size, base=(0.55, 0.5, 0.45)):
    img = np.asarray(base, float) + 0.35 * fbm(rng, size, 4, 6)[..., None]
    tint = 0.15 * fbm(rng, size, 3, 3)
    img[..., 0] += tint
    img[..., 2] -= tint
    _speckle(rng, img, 0.05, 0.15)
    return img


def _asphalt(rng, size):
    img = np.full((size, size, 3), 0.28) + 0.08 * fbm(rng, size, 8, 5)[..., None]
    H = size
    n = size * size // 40
    ys, xs = rng.integers(0, H, n), rng.integers(0, H, n)
    vals = rng.choice([0.08, 0.5, 0.65], size=n, p=[0.4, 0.4, 0.2])
    img[ys, xs] = vals[:, None]
    for _ in range(size // 6):                                   # larger aggregate stones
        _wrap_disc(img, rng.integers(0, H), rng.integers(0, H), rng.uniform(1, 2.5),
                   np.full(3, rng.uniform(0.1, 0.6)))
    _cracks(rng, img, 3, size // 2, (0.05, 0.05, 0.05))
    return img


def _pavement(rng, size, tiles=8):
    """Concrete pavers, running bond, per-tile colour jitter, grout, cracks, speckle."""
    img = np.zeros((size, size, 3))
    t = size // tiles
    base = np.array([0.62, 0.58, 0.52])
    for r in range(tiles):
        off = rng.integers(0, t)
        for c in range(tiles + 1):
            col = _jitter(rng, base * rng.uniform(0.75, 1.2), 0.015)
            _wrap_rect(img, r * t, off + c * t, t, t, col)
    img += 0.12 * fbm(rng, size, 8, 5)[..., None]
    for r in range(tiles):                                        # grout lines
        _wrap_rect(img, r * t, 0, 2, size, (0.25, 0.24, 0.22))
    for r in range(tiles):
        xs = rng.integers(0, size, tiles)
        for x in xs:
            _wrap_rect(img, r * t, x, t, 2, (0.27, 0.25, 0.23))
    _cracks(rng, img, tiles, t, (0.15, 0.14, 0.13))
    for _ in range(size // 3):                                    # lichen / stains
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(1, 4),
                   _jitter(rng, (0.4, 0.4, 0.35), 0.1), 0.6)
    _speckle(rng, img, 0.08, 0.12)
    return img


def _brick(rng, size, rows=16, base=(0.6, 0.3, 0.22)):
    img = np.full((size, size, 3), 0.78) * np.array([1.0, 0.97, 0.92])   # mortar
    h = size // rows
    w = 2 * h + h // 2
    for r in range(rows):
        off = (r % 2) * w // 2 + rng.integers(-2, 3)
        for c in range(size // w + 2):
            col = _jitter(rng, np.asarray(base) * rng.uniform(0.7, 1.25), 0.04)
            _wrap_rect(img, r * h + 1, off + c * w + 1, h - 2, w - 2, col)
    img += 0.10 * fbm(rng, size, 8, 5)[..., None]
    _speckle(rng, img, 0.1, 0.1)
    return img


def _window(rng, img, y0, x0, h, w):
    frame = _jitter(rng, (0.85, 0.85, 0.8), 0.05)
    _wrap_rect(img, y0, x0, h, w, frame)
    glass = _jitter(rng, (0.25, 0.32, 0.4), 0.08)
    b = max(2, w // 10)
    _wrap_rect(img, y0 + b, x0 + b, h - 2 * b, w - 2 * b, glass)
    for _ in range(rng.integers(2, 6)):                              # interior / reflections
        hh, ww = rng.integers(2, max(3, h // 2)), rng.integers(2, max(3, w // 2))
        _wrap_rect(img, y0 + b + rng.integers(0, max(1, h - 2 * b - hh)),
                   x0 + b + rng.integers(0, max(1, w - 2 * b - ww)), hh, ww,
                   _jitter(rng, glass * rng.uniform(0.6, 2.2), 0.1), 0.8)
    if rng.random() < 0.5:                                           # curtain
        _wrap_rect(img, y0 + b, x0 + b, (h - 2 * b) * rng.uniform(0.2, 0.6), w - 2 * b,
                   _jitter(rng, (0.8, 0.75, 0.6), 0.1))
    _wrap_rect(img, y0 + h // 2, x0, 2, w, frame)                   # transom / mullion
    _wrap_rect(img, y0, x0 + w // 2, h, 2, frame)


def _facade(rng, size):
    """Brick or plaster storey with two irregular windows (texture covers about 4 m x 4 m)."""
    img = _brick(rng, size, rows=32) if rng.random() < 0.6 else _plaster(rng, size)
    for k in range(2):
        w = int(size * rng.uniform(0.22, 0.3))
        h = int(size * rng.uniform(0.35, 0.45))
        _window(rng, img, int(size * 0.25) + rng.integers(-4, 5), k * size // 2 + size // 8, h, w)
        _wrap_rect(img, int(size * 0.25) + h, k * size // 2 + size // 8 - 3, 4, w + 6, (0.75,) * 3)
    return img


def _plaster(rng, size):
    img = np.asarray(_jitter(rng, (0.82, 0.78, 0.68), 0.04)) + 0.12 * fbm(rng, size, 6, 6)[..., None]
    for _ in range(size // 8):
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(1, 5),
                   _jitter(rng, (0.55, 0.5, 0.45), 0.08), 0.5)
    _cracks(rng, img, 4, size // 3, (0.4, 0.38, 0.35))
    _speckle(rng, img, 0.06, 0.1)
    return img


def _concrete(rng, size):
    img = np.full((size, size, 3), 0.6) + 0.15 * fbm(rng, size, 5, 6)[..., None]
    for _ in range(size // 2):
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(0.7, 2.5),
                   np.full(3, rng.uniform(0.2, 0.45)), 0.8)
    _wrap_rect(img, size // 2, 0, 2, size, (0.35,) * 3)               # form-work joints
    _wrap_rect(img, 0, rng.integers(0, size), size, 2, (0.35,) * 3)
    _speckle(rng, img, 0.08, 0.12)
    return img


def _poster(rng, size):
    img = np.ones((size, size, 3)) * _jitter(rng, (0.9, 0.9, 0.85), 0.1)
    for _ in range(rng.integers(4, 9)):
        col = rng.random(3)
        if rng.random() < 0.5:
            _wrap_rect(img, rng.integers(0, size), rng.integers(0, size),
                       rng.integers(size // 10, size // 2), rng.integers(size // 10, size // 2), col)
        else:
            _wrap_disc(img, rng.integers(0, size), rng.integers(0, size),
                       rng.uniform(size / 20, size / 5), col)
    for line in range(rng.integers(3, 8)):                           # "text": rows of glyph blocks
        y = rng.integers(0, size)
        x = rng.integers(0, size // 4)
        gh = rng.integers(size // 40 + 2, size // 16 + 3)
        col = rng.random(3) * 0.4
        while x < size * 0.9:
            gw = rng.integers(gh // 2, gh + 1)
            if rng.random() < 0.85:
                _wrap_rect(img, y, x, gh, gw, col)
            x += gw + rng.integers(1, gh // 2 + 2)
    return img


def _graffiti(rng, size):
    img = _concrete(rng, size)
    for _ in range(rng.integers(5, 10)):
        col = rng.random(3)
        y, x = rng.uniform(0, size, 2)
        ang = rng.uniform(0, 2 * np.pi)
        r = rng.uniform(2, 6)
        for _ in range(rng.integers(size // 2, size * 2)):
            ang += rng.normal(0, 0.3)
            y, x = y + 1.5 * np.sin(ang), x + 1.5 * np.cos(ang)
            _wrap_disc(img, y, x, r, col)
    return img


def _bark(rng, size):
    img = np.asarray((0.36, 0.27, 0.18)) + 0.25 * fbm(rng, size, 16, 4, aspect=8.0)[..., None]
    img += 0.1 * fbm(rng, size, 8, 4)[..., None]
    for _ in range(size // 4):                                       # fissures, knots
        _wrap_rect(img, rng.integers(0, size), rng.integers(0, size), rng.integers(8, 40), 2,
                   (0.12, 0.09, 0.06))
    for _ in range(6):
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(2, 5), (0.2, 0.14, 0.08))
    _speckle(rng, img, 0.05, 0.1)
    return img


def _stamp_discs(img, ys, xs, rs, cols):
    """Discs (centres ``ys``, ``xs``, radii ``rs``, colours ``cols`` (N, 3)) painted in order with wrap-around:
    where discs overlap the later one wins (vectorised :func:`_wrap_disc` with alpha 1)."""
    H, W = img.shape[:2]
    r_max = int(np.ceil(np.max(rs)))
    dy, dx = np.mgrid[-r_max:r_max + 1, -r_max:r_max + 1]
    d2 = (dy ** 2 + dx ** 2).ravel()
    inside = d2[None, :] <= np.square(rs)[:, None]                       # (N, K)
    order, k = np.nonzero(inside)
    pix = ((ys.astype(int)[order] + dy.ravel()[k]) % H) * W + (xs.astype(int)[order] + dx.ravel()[k]) % W
    last = np.full(H * W, -1)
    np.maximum.at(last, pix, order)
    flat = img.reshape(-1, 3)
    hit = last >= 0
    flat[hit] = cols[last[hit]]


def _foliage(rng, size, base=(0.2, 0.42, 0.16)):
    img = np.asarray(base) * 0.35 + 0.05 * fbm(rng, size, 4, 3)[..., None]
    n = size * size // 40
    base = np.asarray(base)
    cols = np.clip(base * rng.uniform(0.6, 1.5, n)[:, None] + rng.normal(0, 0.05, (n, 3)), 0, 1)
    _stamp_discs(img, rng.integers(0, size, n), rng.integers(0, size, n), rng.uniform(1.0, 3.5, n), cols)
    return img


def _grass(rng, size):
    img = np.asarray((0.3, 0.45, 0.2)) + 0.15 * fbm(rng, size, 8, 5)[..., None] * np.array([0.6, 1, 0.5])
    n = size * size // 6
    ys, xs = rng.integers(0, size, n), rng.integers(0, size, n)
    img[ys, xs] = (np.array([0.3, 0.5, 0.2]) * rng.uniform(0.4, 1.5, n)[:, None])
    for _ in range(size // 8):                                       # bare soil / leaves
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(1, 4),
                   _jitter(rng, (0.45, 0.38, 0.25), 0.06))
    return img


def _carpet(rng, size):
    base = _jitter(rng, (0.35, 0.38, 0.5), 0.08)
    img = base + 0.08 * fbm(rng, size, 16, 3)[..., None]
    for _ in range(size // 2):                                       # flecks and stains
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(0.6, 3),
                   _jitter(rng, base * rng.uniform(0.4, 1.8), 0.08))
    _speckle(rng, img, 0.3, 0.12)
    return img


def _wood(rng, size, planks=6):
    img = np.zeros((size, size, 3))
    y = np.arange(size)[:, None]
    h = size // planks
    for p in range(planks):
        warp = 6 * fbm(rng, size, 4, 3)
        freq = rng.uniform(0.25, 0.5)
        rings = 0.5 + 0.5 * np.sin(freq * (y + warp * 3 + rng.uniform(0, 50)))
        col = _jitter(rng, (0.55, 0.38, 0.2), 0.05)
        sl = slice(p * h, (p + 1) * h)
        img[sl] = (col * (0.75 + 0.25 * rings[..., None]))[sl]
        _wrap_rect(img, p * h, rng.integers(0, size), h, 2, (0.2, 0.12, 0.06))
        _wrap_rect(img, p * h, 0, 1, size, (0.2, 0.12, 0.06))
    img = img.transpose(1, 0, 2).copy()                               # grain along y (vertical)
    for _ in range(8):
        _wrap_disc(img, rng.integers(0, size), rng.integers(0, size), rng.uniform(2, 5), (0.3, 0.18, 0.08))
    return img


def _checkerboard(rng, size, squares=8):
    """Calibration board: checkerboard with a white margin and a few coded dots."""
    img = np.ones((size, size, 3))
    m = size // (squares + 2)
    for r in range(squares):
        for c in range(squares):
            if (r + c) % 2 == 0:
                _wrap_rect(img, m + r * m, m + c * m, m, m, (0.05,) * 3)
    for _ in range(6):
        _wrap_disc(img, rng.integers(m // 2, m), rng.integers(m, size - m), m / 6, (0.05,) * 3)
    return img


GENERATORS = {
    "noise": _noise_tex, "asphalt": _asphalt, "pavement": _pavement, "brick": _brick,
    "facade": _facade, "plaster": _plaster, "concrete": _concrete, "poster": _poster,
    "graffiti": _graffiti, "bark": _bark, "foliage": _foliage, "grass": _grass,
    "carpet": _carpet, "wood": _wood, "checkerboard": _checkerboard,
}


def texture_kinds() -> tuple:
    return tuple(sorted(GENERATORS))


def weather(img: np.ndarray, rng: np.random.Generator, stickers: bool = True) -> np.ndarray:
    """One surface instance's own look on a square ``(H, H, 3) uint8`` texture ``img``: a colour and brightness
    shift, grime (darkening where a stretched fractal noise is positive) and one to four decals (stickers unless
    ``stickers`` is false, stains), all wrapping around the borders so the texture stays tileable. A generator in the same state gives the
    same bytes."""
    H = img.shape[0]
    if img.ndim != 3 or img.shape[1] != H or img.dtype != np.uint8:
        raise SceneError(f"weather: expected a square (H, H, 3) uint8 texture, got {img.shape} {img.dtype}")
    f = img.astype(float) / 255.0
    f = f * rng.uniform(0.88, 1.12) * np.clip(1.0 + rng.normal(0.0, 0.05, 3), 0.8, 1.2)
    grime = fbm(rng, H, 2, 4, aspect=float(rng.choice([0.25, 1.0, 4.0])))
    f *= (1.0 - rng.uniform(0.06, 0.2) * np.clip(grime, 0.0, None))[..., None]
    mean = f.reshape(-1, 3).mean(axis=0)
    for _ in range(int(rng.integers(1, 5))):
        y, x = rng.integers(0, H, 2)
        if rng.random() < 0.5 and stickers:                               # a sticker / sign
            h, w = (H * rng.uniform(0.04, 0.12, 2)).astype(int) + 2
            _wrap_rect(f, y, x, h, w, rng.uniform(0.1, 0.95, 3), 0.9)
            _wrap_rect(f, y + h // 3, x + 1, max(1, h // 6), max(1, w - 2), rng.uniform(0.0, 0.3, 3), 0.9)
        else:                                                             # a stain
            _wrap_disc(f, y, x, H * rng.uniform(0.03, 0.1), mean * rng.uniform(0.4, 0.7), 0.5)
    return np.clip(np.round(f * 255.0), 0, 255).astype(np.uint8)


def make_texture(kind: str, rng: np.random.Generator, richness: float, size: int = 256) -> np.ndarray:
    """A ``(size, size, 3) uint8`` RGB texture of ``kind`` drawn from ``rng``; a generator in the same
    state gives the same bytes.

    ``richness`` in [0, 1] scales the contrast of all detail around the mean colour
    (0 = one flat colour).
    """
    if kind not in GENERATORS:
        raise SceneError(f"texture kind {kind!r} unknown; valid: {', '.join(texture_kinds())}")
    if not 0.0 <= float(richness) <= 1.0:
        raise SceneError(f"texture richness: must be in [0, 1], got {richness!r}")
    if int(size) < 16 or int(size) & (int(size) - 1):
        raise SceneError(f"texture size: must be a power of two >= 16, got {size!r}")
    if not isinstance(rng, np.random.Generator):
        raise SceneError(f"texture rng: expected a numpy Generator, got {type(rng).__name__}")
    return with_richness(GENERATORS[kind](rng, int(size)), richness)


def with_richness(full: np.ndarray, richness: float) -> np.ndarray:
    """``(H, W, 3)`` float image, clipped to [0, 1] -> ``uint8``: ``mean + richness * (full - mean)``."""
    full = np.clip(full, 0.0, 1.0)
    mean = full.reshape(-1, 3).mean(axis=0)
    return np.clip(np.round((mean + float(richness) * (full - mean)) * 255.0), 0, 255).astype(np.uint8)
