"""Printed matter and bookshelves for the indoor scene, each drawn as an instance of its own.

A real poster is not a grid of alike glyph blocks: it has a headline in large letters, a photo, paragraphs of
running text whose words differ in length, a logo, a footer. Seen from 2-5 m, body text is a row of word blobs
(letters merge; ascenders and descenders make their top and bottom edges ragged), and headline letters are large
enough to show their counters and notches. So corners on a print differ from one another by what surrounds them,
as on a real one (the plain glyph-block rows of :func:`scenes.textures._poster` put alike corners on every poster,
a look-alike place between the corridor's poster and a shelf in ``validate places``).

A shelf carries books, binders and boxes of varied width, height and colour on boards, not a poster pattern.

Every function draws a full-contrast float image in [0, 1] from the generator it is given (a generator in the same
state gives the same bytes); :func:`scenes.textures.with_richness` blends it towards its mean colour by the
scene's ``richness`` (as :func:`scenes.textures.make_texture` does) and makes it ``uint8``. Row 0 is the top.
"""
from __future__ import annotations

import numpy as np

from scenes.indoor_walls import fbm_rect
from scenes.textures import _wrap_disc


def _rect(img, y, x, h, w, col):
    """Clipped (non-wrapping) filled rectangle."""
    H, W = img.shape[:2]
    y0, x0, y1, x1 = max(0, int(y)), max(0, int(x)), min(H, int(y + h)), min(W, int(x + w))
    if y1 > y0 and x1 > x0:
        img[y0:y1, x0:x1] = col


def words(rng, img, y, x0, x1, xh, ink, paper, headline=False):
    """One line of text at row ``y`` (top of the x-height ``xh``, texels) from column ``x0`` to at most ``x1``:
    words of 1-11 letters of their own widths; ascenders (d, h, k ...) and descenders (g, p, y ...) at random;
    headline letters (``headline``) show a counter or notch in ``paper`` colour. Returns the end column."""
    x, end = int(x0), int(x0)
    gap = max(1, xh // 2)
    while True:
        n = int(rng.integers(1, 12))
        widths = rng.integers(max(1, xh // 2), xh + 2, n)
        if x + widths.sum() + n > x1:
            return end
        for lw in widths:
            top = y - (xh // 2 + 1 if rng.random() < 0.3 else 0)
            bot = y + xh + (xh // 3 + 1 if rng.random() < 0.12 else 0)
            _rect(img, top, x, bot - top, lw, ink)
            if headline and lw >= 3 and rng.random() < 0.8:
                t = int(rng.integers(0, 4))                       # counter (o, e), notch from top (u), bottom (n)
                cw = max(1, lw // 3)
                cx = x + (lw - cw) // 2
                if t == 0:
                    _rect(img, y + xh // 3, cx, max(1, xh // 3), cw, paper)
                elif t == 1:
                    _rect(img, top, cx, max(1, (y + xh // 2) - top), cw, paper)
                elif t == 2:
                    _rect(img, y + xh // 2, cx, bot - y - xh // 2, cw, paper)
                else:
                    _rect(img, y + xh // 3, cx, max(1, xh // 4), lw - cw // 2, paper)
            x += int(lw) + (1 if headline or rng.random() < 0.3 else 0)
        end = x
        x += int(rng.integers(gap, gap + max(2, xh // 2)))


def paragraph(rng, img, y, x0, x1, xh, ink, paper, y_end):
    """Running text from row ``y`` to at most ``y_end``: lines of words, a short last line, a blank line after
    each paragraph. Returns the row after it."""
    lead = int(xh * rng.uniform(1.9, 2.6))
    while y + xh < y_end:
        for _ in range(int(rng.integers(2, 7))):
            if y + xh >= y_end:
                return y
            stop = x1 if rng.random() > 0.2 else int(x0 + (x1 - x0) * rng.uniform(0.3, 0.8))
            words(rng, img, y, x0 + (xh if rng.random() < 0.15 else 0), stop, xh, ink, paper)
            y += lead
        y += lead
    return y


def photo(rng, h: int, w: int) -> np.ndarray:
    """A ``(h, w, 3)`` photo-like picture: a scene (sky, a ragged horizon, ground with objects) or a product shot
    (an object with shading against a plain backdrop), with its own colours."""
    img = np.empty((h, w, 3))
    if rng.random() < 0.6:
        sky = rng.uniform(0.4, 0.95, 3)
        img[:] = sky * (0.8 + 0.25 * np.linspace(0, 1, h))[:, None, None]
        line = (h * rng.uniform(0.3, 0.6) + h * 0.2 * fbm_rect(rng, 1, w, w / 3.0, 4)[0]).astype(int)
        ground = rng.uniform(0.1, 0.6, 3)
        tex = 0.25 * fbm_rect(rng, h, w, max(2.0, w / 6.0), 5)
        rows = np.arange(h)[:, None]
        below = rows >= line[None, :]
        img[below] = (ground + tex[..., None] * ground)[below]
        for _ in range(int(rng.integers(4, 11))):                # trees, people, buildings
            cx, cy = rng.integers(0, w), int(np.clip(line[rng.integers(0, w)], 0, h - 1))
            col = rng.uniform(0.0, 0.9, 3)
            if rng.random() < 0.5:
                bw, bh = int(w * rng.uniform(0.05, 0.25)), int(h * rng.uniform(0.1, 0.5))
                _rect(img, cy - bh, cx, bh, bw, col)
            else:
                _wrap_disc(img, cy - h * 0.1, cx, rng.uniform(0.04, 0.14) * min(h, w) + 1, col)
    else:
        back = rng.uniform(0.3, 1.0, 3)
        img[:] = back + 0.08 * fbm_rect(rng, h, w, max(2.0, w / 3.0), 3)[..., None]
        col = rng.uniform(0.0, 1.0, 3)
        r = rng.uniform(0.2, 0.4) * min(h, w)
        yy, xx = np.mgrid[0:h, 0:w]
        cy, cx = h * rng.uniform(0.35, 0.65), w * rng.uniform(0.3, 0.7)
        d = np.hypot(yy - cy, (xx - cx) * rng.uniform(0.6, 1.4))
        inside = d < r
        shade = 0.6 + 0.5 * (1.0 - d / r) + 0.15 * (xx - cx) / max(r, 1)
        img[inside] = (col * shade[..., None])[inside]
        _rect(img, cy + r * 0.7, cx - r * 1.3, max(1, r * 0.12), r * 2.6, col * 0.4)     # its shadow / a table edge
    return img


def print_image(rng, size: int) -> np.ndarray:
    """``(size, size, 3)`` float: a poster, notice or flyer of its own (header, headline, photo, body text, logo)."""
    S = int(size)
    paper = np.clip(rng.uniform(0.85, 0.98) + rng.normal(0.0, 0.02, 3), 0, 1)
    if rng.random() < 0.3:
        paper = rng.uniform(0.55, 0.95, 3)
    img = np.ones((S, S, 3)) * paper
    ink = rng.uniform(0.0, 0.3, 3)
    m = int(S * rng.uniform(0.04, 0.08))                          # margin
    y = m
    if rng.random() < 0.5:                                        # a coloured header band, headline in it
        bh = int(S * rng.uniform(0.12, 0.25))
        band = rng.uniform(0.0, 1.0, 3)
        _rect(img, 0, 0, bh, S, band)
        hi = np.where(band.mean() > 0.5, 0.05, 0.95) * np.ones(3)
        xh = int(S * rng.uniform(0.05, 0.08))
        words(rng, img, (bh - xh) // 2, m, S - m, xh, hi, band, headline=True)
        y = bh + m // 2
    else:
        for _ in range(int(rng.integers(1, 3))):
            xh = int(S * rng.uniform(0.045, 0.08))
            words(rng, img, y + xh // 2, m + int(rng.integers(0, S // 6)), S - m, xh, ink, paper, headline=True)
            y += int(xh * 2.2)
    if rng.random() < 0.3:                                        # a subheading
        xh = int(S * rng.uniform(0.025, 0.035))
        words(rng, img, y, m, S - m - int(rng.integers(0, S // 3)), xh, rng.uniform(0.0, 0.8, 3), paper)
        y += int(xh * 2.5)
    text_xh = max(2, int(S * rng.uniform(0.02, 0.032)))
    if rng.random() < 0.75:                                       # a photo, full width or beside the text
        ph = int(S * rng.uniform(0.2, 0.4))
        if rng.random() < 0.5:
            pw, px = S - 2 * m, m
        else:
            pw = int(S * rng.uniform(0.35, 0.55))
            px = m if rng.random() < 0.5 else S - m - pw
            tx0, tx1 = (px + pw + m // 2, S - m) if px == m else (m, px - m // 2)
            paragraph(rng, img, y, tx0, tx1, text_xh, ink, paper, min(S - m, y + ph))
        img[y:y + ph, px:px + pw] = photo(rng, min(ph, S - y), pw)[: S - y]
        y += ph + m // 2
    cols = 2 if rng.random() < 0.35 else 1
    cw = (S - 2 * m - (cols - 1) * m // 2) // cols
    y_end = S - m - (int(S * 0.08) if rng.random() < 0.6 else 0)
    for c in range(cols):
        x0 = m + c * (cw + m // 2)
        paragraph(rng, img, y, x0, x0 + cw, text_xh, ink, paper, y_end)
    if y_end < S - m:                                             # footer: a logo and a line of small print
        r = S * rng.uniform(0.025, 0.045)
        lx = m + r if rng.random() < 0.5 else S - m - r
        _wrap_disc(img, S - m - r, lx, r, rng.uniform(0.0, 1.0, 3))
        _wrap_disc(img, S - m - r, lx + r * rng.uniform(-0.4, 0.4), r * rng.uniform(0.3, 0.6), paper)
        fx0 = m + 3 * r if lx < S / 2 else m
        words(rng, img, S - m - r, fx0, fx0 + int((S - 2 * m - 3 * r) * rng.uniform(0.4, 0.9)),
              max(2, text_xh - 1), ink, paper)
    return img


def shelf_image(rng, size: int) -> np.ndarray:
    """``(size, size, 3)`` float: the front of a bookshelf with boards every
    0.3-0.45 of a 2 m height and books, binders and boxes of their own widths, heights and colours, gaps between."""
    S = int(size)
    wood = rng.uniform(0.3, 0.85) * np.asarray((1.0, 0.85, 0.65) if rng.random() < 0.6 else (1.0, 1.0, 1.0))
    img = np.ones((S, S, 3)) * wood * 0.45                        # the shelf's back, in shadow
    img += 0.04 * fbm_rect(rng, S, S, S / 8.0, 4)[..., None]
    board = max(2, S // 64)
    y = 0
    while y < S:
        comp = int(S * rng.uniform(0.15, 0.22))
        _rect(img, y, 0, board, S, wood)
        _rect(img, y + board, 0, 1, S, wood * 0.5)
        base = min(S, y + comp)
        x = int(rng.integers(0, S // 20 + 1))
        while x < S:
            kind = rng.random()
            if kind < 0.08:                                       # a gap
                x += int(rng.integers(S // 40, S // 8))
                continue
            if kind < 0.25:                                       # a binder: wide, a label and a ring hole
                w, h = int(rng.integers(S // 40, S // 20) + 2), int((comp - board) * rng.uniform(0.75, 0.95))
                col = rng.uniform(0.05, 0.95, 3)
                _rect(img, base - h, x, h, w, col)
                _rect(img, base - h + h // 5, x + 1, max(2, h // 4), max(1, w - 2), np.clip(col + 0.5, 0, 1))
                _wrap_disc(img, base - h // 4, x + w / 2, max(0.8, w / 6), (0.1, 0.1, 0.1))
            elif kind < 0.33:                                     # a box or a stack of papers
                w, h = int(rng.integers(S // 16, S // 6)), int((comp - board) * rng.uniform(0.2, 0.6))
                col = rng.uniform(0.2, 0.95, 3)
                _rect(img, base - h, x, h, w, col)
                for k in range(int(rng.integers(0, 4))):
                    _rect(img, base - h + 1 + k * 2, x, 1, w, col * 0.7)
            else:                                                 # a run of books
                for _ in range(int(rng.integers(2, 12))):
                    w, h = int(rng.integers(2, max(3, S // 50) + 2)), int((comp - board) * rng.uniform(0.55, 0.92))
                    col = rng.uniform(0.05, 0.9, 3)
                    _rect(img, base - h, x, h, w, col)
                    if rng.random() < 0.6:                        # a spine label
                        _rect(img, base - h + int(h * rng.uniform(0.1, 0.7)), x, max(1, h // 10), w,
                              np.clip(col * rng.uniform(0.2, 1.8), 0, 1))
                    x += w + (1 if rng.random() < 0.3 else 0)
                    if x >= S:
                        break
            x += int(rng.integers(0, 3)) + (w if kind < 0.33 else 0)
        y += comp
    _rect(img, 0, 0, S, board, wood)                              # side panels
    _rect(img, 0, S - board, S, board, wood)
    return img
