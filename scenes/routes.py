"""Route geometry helpers (numpy only): rounded polylines, arc-length sampling, distances."""
from __future__ import annotations

import numpy as np


def polyline_length(xy, closed=False) -> float:
    """Length (m) of a polyline (N, 2), including the closing segment if ``closed``."""
    xy = np.asarray(xy, float)
    if closed:
        xy = np.vstack([xy, xy[:1]])
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())


def resample(xy, step, closed=False) -> np.ndarray:
    """Points every ``step`` metres of arc length along a polyline (first point kept)."""
    xy = np.asarray(xy, float)
    pts = np.vstack([xy, xy[:1]]) if closed else xy
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    n = max(2, int(round(s[-1] / step)) + (0 if closed else 1))
    q = np.linspace(0, s[-1], n, endpoint=not closed)
    return np.stack([np.interp(q, s, pts[:, 0]), np.interp(q, s, pts[:, 1])], axis=1)


def point_at(xy, s_query, closed=False) -> np.ndarray:
    """(K, 2) points at arc lengths ``s_query`` (m) along a polyline."""
    xy = np.asarray(xy, float)
    pts = np.vstack([xy, xy[:1]]) if closed else xy
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    q = np.atleast_1d(np.asarray(s_query, float))
    return np.stack([np.interp(q, s, pts[:, 0]), np.interp(q, s, pts[:, 1])], axis=1)


def rounded_polyline(corners, radius, step=0.25, closed=False) -> np.ndarray:
    """Dense polyline through ``corners`` (N, 2) with every interior corner replaced by a circular
    arc of ``radius`` (m) tangent to both legs; open ends are kept.  Points about ``step`` apart."""
    c = np.asarray(corners, float)
    n = len(c)
    out = []
    idx = range(n) if closed else range(n)
    for i in idx:
        if not closed and i in (0, n - 1):
            out.append([c[i]])
            continue
        p0, p1, p2 = c[i - 1], c[i], c[(i + 1) % n]
        d0 = (p1 - p0) / np.linalg.norm(p1 - p0)
        d1 = (p2 - p1) / np.linalg.norm(p2 - p1)
        turn = np.arctan2(d0[0] * d1[1] - d0[1] * d1[0], d0 @ d1)
        if abs(turn) < 1e-9:
            out.append([p1])
            continue
        t = radius * np.tan(abs(turn) / 2)                   # tangent length from the corner
        a = p1 - d0 * t
        nrm = np.array([-d0[1], d0[0]]) * np.sign(turn)      # towards the arc centre
        ctr = a + nrm * radius
        k = max(2, int(np.ceil(abs(turn) * radius / step)) + 1)
        ang0 = np.arctan2(a[1] - ctr[1], a[0] - ctr[0])
        ang = ang0 + np.linspace(0, turn, k)
        out.append(ctr + radius * np.stack([np.cos(ang), np.sin(ang)], axis=1))
    dense = np.vstack(out)
    return resample(dense, step, closed=closed) if len(dense) > 1 else dense


def distance_to_polyline(points, xy, closed=False) -> np.ndarray:
    """(K,) distance (m) from points (K, 2) to a polyline (N, 2)."""
    p = np.atleast_2d(np.asarray(points, float))
    pts = np.asarray(xy, float)
    if closed:
        pts = np.vstack([pts, pts[:1]])
    a, b = pts[:-1], pts[1:]
    ab = b - a
    t = np.clip(((p[:, None, :] - a[None]) * ab[None]).sum(-1) / np.maximum((ab ** 2).sum(-1), 1e-12), 0, 1)
    proj = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - proj, axis=-1).min(axis=1)
