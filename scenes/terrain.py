"""Seeded height fields with craters and rocks (numpy only), for a lunar-terrain scene.

Crater profile (a simple, common fresh-crater model; radius R, depth d = depth_ratio * 2R):
inside, a parabolic bowl ``z = -d + (d + h_rim) * (r / R)^2`` reaching the rim height ``h_rim`` at
r = R; outside, an ejecta blanket decaying as ``h_rim * (R / r)^3``.  Craters add to each other.
Rocks are smooth bumps ``h * max(0, 1 - (r / a)^2)^2`` (a = rock radius).  The grid is regular:
``z[i, j]`` is the height at ``x = x0 + j * res``, ``y = y0 + i * res`` (row i = y, column j = x).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.errors import SceneError


@dataclass(frozen=True)
class Crater:
    x: float
    y: float
    radius: float          # rim radius (m)
    depth_ratio: float = 0.2   # depth / diameter
    rim_ratio: float = 0.04    # rim height / diameter


def crater_profile(r, crater: Crater) -> np.ndarray:
    """Height (m) at distances ``r`` (m) from the crater centre."""
    r = np.asarray(r, float)
    R = crater.radius
    d, h = crater.depth_ratio * 2 * R, crater.rim_ratio * 2 * R
    inside = -d + (d + h) * (r / R) ** 2
    outside = h * (R / np.maximum(r, R)) ** 3
    return np.where(r <= R, inside, outside)


def grid_xy(extent, res):
    """(x (W,), y (H,)) grid coordinates for ``extent = (xmin, xmax, ymin, ymax)`` at ``res`` m."""
    xmin, xmax, ymin, ymax = map(float, extent)
    if res <= 0 or xmax <= xmin or ymax <= ymin:
        raise SceneError(f"terrain grid: need res > 0 and a non-empty extent, got res={res}, extent={extent}")
    return np.arange(xmin, xmax + 1e-9, res), np.arange(ymin, ymax + 1e-9, res)


def heightfield(extent, res, craters=(), rocks=(), roughness=0.0, rng=None) -> np.ndarray:
    """(H, W) height grid (m): sum of crater profiles, rock bumps ``(x, y, radius, height)`` and,
    if ``roughness`` > 0, seeded smooth noise of that standard deviation (needs ``rng``)."""
    x, y = grid_xy(extent, res)
    X, Y = np.meshgrid(x, y)
    z = np.zeros_like(X)
    for c in craters:
        z += crater_profile(np.hypot(X - c.x, Y - c.y), c)
    for (rx, ry, ra, rh) in rocks:
        q = np.clip(1 - ((X - rx) ** 2 + (Y - ry) ** 2) / ra ** 2, 0, None)
        z += rh * q ** 2
    if roughness > 0:
        if rng is None:
            raise SceneError("terrain roughness > 0 needs an explicit numpy Generator rng")
        from scenes.textures import fbm
        n = 1 << int(np.ceil(np.log2(max(z.shape))))
        noise = fbm(rng, n, 4, 5)[: z.shape[0], : z.shape[1]]
        z += roughness * noise / max(noise.std(), 1e-12)
    return z


def random_craters(rng: np.random.Generator, extent, n, r_min=0.5, r_max=8.0, slope=2.0) -> tuple:
    """``n`` craters, uniform positions, power-law radii (density ~ r^-slope) in [r_min, r_max]."""
    xmin, xmax, ymin, ymax = extent
    u = rng.random(n)
    a = 1 - slope
    r = (r_min ** a + u * (r_max ** a - r_min ** a)) ** (1 / a)
    xs, ys = rng.uniform(xmin, xmax, n), rng.uniform(ymin, ymax, n)
    return tuple(Crater(float(px), float(py), float(pr)) for px, py, pr in zip(xs, ys, r))


def random_rocks(rng: np.random.Generator, extent, n, a_min=0.1, a_max=0.6) -> tuple:
    """``n`` rocks ``(x, y, radius, height)`` with height 0.3-0.7 x radius."""
    xmin, xmax, ymin, ymax = extent
    a = rng.uniform(a_min, a_max, n)
    return tuple((float(px), float(py), float(pa), float(pa * h)) for px, py, pa, h in
                 zip(rng.uniform(xmin, xmax, n), rng.uniform(ymin, ymax, n), a, rng.uniform(0.3, 0.7, n)))
