"""Descriptor front-end option of the ROP estimator: a thin adapter over :mod:`vo.frontend`.

``"orb"`` / ``"sift"``: each of the four pairs 1-3, 1-4, 2-3, 2-4 is matched independently with
:func:`vo.frontend.correspondences.correspondences` (detector, ratio test, cross-check), i.e. four
matchings per frame - slower and less precise than the KLT four-view tracks (``"klt"``, default,
:mod:`vo.rop.tracks`), kept for comparison with seed 000 (which used SURF).
"""
from __future__ import annotations

from vo.frontend.correspondences import correspondences
from vo.rop.relative import normalized_points
from vo.rop.ropset import PAIRS

KINDS = ("klt", "orb", "sift")


def descriptor_pairs(imgs: dict, cams, kind: str) -> dict:
    """``imgs`` {1,2,3,4: image} -> {pair: (x_i, x_j) normalized undistorted matches (N,2)}."""
    out = {}
    for p in PAIRS:
        i, j = int(p[0]), int(p[1])
        a, b = correspondences(imgs[i], imgs[j], kind)
        ci, cj = cams[(i - 1) % 2], cams[(j - 1) % 2]
        out[p] = (normalized_points(a, ci.K, ci.dist_coeffs), normalized_points(b, cj.K, cj.dist_coeffs))
    return out
