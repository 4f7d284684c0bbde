"""The one correspondence function other estimators (e.g. ``vo.rop``) call: pixels matched between two images."""
from __future__ import annotations

import numpy as np

from vo.errors import VoError
from vo.frontend.descriptors import DescriptorConfig, match_images
from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig, detect_in_empty_cells, track_fb

KINDS = ("klt", "orb", "sift")


def correspondences(img_a: np.ndarray, img_b: np.ndarray, kind: str = "klt", config=None) -> tuple:
    """Matched pixels between two grayscale uint8 images -> ``(p_a (N,2) float64, p_b (N,2) float64)``.

    ``klt``: one Shi-Tomasi corner per non-border grid cell of ``img_a``, LK ``a -> b`` with the
    forward-backward check (``config``: :class:`KltConfig`). ``orb`` / ``sift``: descriptor matching with
    ratio test and cross-check (``config``: :class:`DescriptorConfig`). Raw (distorted) pixel coordinates.
    """
    if kind not in KINDS:
        raise VoError(f"correspondence kind {kind!r} unknown; valid: {', '.join(KINDS)}")
    if img_a.shape[:2] != img_b.shape[:2]:
        raise VoError(f"correspondences: image sizes differ {img_a.shape[:2]} vs {img_b.shape[:2]}")
    if kind == "klt":
        cfg = config or KltConfig()
        h, w = img_a.shape[:2]
        p_a = detect_in_empty_cells(img_a, Grid(w, h, cfg.cell), np.zeros((0, 2)), cfg)
        p_b, ok = track_fb(img_a, img_b, p_a, cfg)
        return p_a[ok], p_b[ok]
    return match_images(img_a, img_b, kind, config or DescriptorConfig())
