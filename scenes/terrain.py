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
    if ``roughness`` > 0, seeded smooth noise of that standard deviation (needs ``rng``).
    Each crater is evaluated within :data:`CRATER_REACH` radii of its centre (the ejecta blanket
    there is ``(1 / CRATER_REACH)^3`` = 1.6 % of the rim height; beyond, it is dropped)."""
    x, y = grid_xy(extent, res)
    z = np.zeros((y.size, x.size))
    for c in craters:
        _add_local(z, x, y, c.x, c.y, CRATER_REACH * c.radius, lambda r, c=c: crater_profile(r, c))
    for (rx, ry, ra, rh) in rocks:
        _add_local(z, x, y, rx, ry, ra, lambda r, ra=ra, rh=rh: rh * np.clip(1 - (r / ra) ** 2, 0, None) ** 2)
    if roughness > 0:
        if rng is None:
            raise SceneError("terrain roughness > 0 needs an explicit numpy Generator rng")
        from scenes.textures import fbm
        n = 1 << int(np.ceil(np.log2(max(z.shape))))
        noise = fbm(rng, n, 4, 5)[: z.shape[0], : z.shape[1]]
        z += roughness * noise / max(noise.std(), 1e-12)
    return z


CRATER_REACH = 4.0


def _add_local(z, x, y, cx, cy, reach, profile) -> None:
    """``z += profile(r)`` on the grid cells within ``reach`` of (cx, cy) (r = distance to it)."""
    j0, j1 = np.searchsorted(x, [cx - reach, cx + reach])
    i0, i1 = np.searchsorted(y, [cy - reach, cy + reach])
    if j1 <= j0 or i1 <= i0:
        return
    X, Y = np.meshgrid(x[j0:j1], y[i0:i1])
    z[i0:i1, j0:j1] += profile(np.hypot(X - cx, Y - cy))


def mesh_height(z, extent, res, px, py) -> np.ndarray:
    """Exact height of the triangulated grid ``z`` at world (px, py) (vectorised): cell (i, j) is
    split along its diagonal from (i, j) to (i+1, j+1) into the triangles
    {(i,j), (i,j+1), (i+1,j+1)} (where fx >= fy) and {(i,j), (i+1,j+1), (i+1,j)}, as
    :func:`grid_triangles` builds them. Points outside the grid take the nearest border cell's plane."""
    xmin, _, ymin, _ = map(float, extent)
    H, W = z.shape
    u = (np.asarray(px, float) - xmin) / res
    v = (np.asarray(py, float) - ymin) / res
    j = np.clip(np.floor(u).astype(int), 0, W - 2)
    i = np.clip(np.floor(v).astype(int), 0, H - 2)
    fx, fy = u - j, v - i
    z00, z01, z10, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
    upper = z00 + fx * (z01 - z00) + fy * (z11 - z01)       # fx >= fy
    lower = z00 + fy * (z10 - z00) + fx * (z11 - z10)       # fx < fy
    return np.where(fx >= fy, upper, lower)


def grid_triangles(n_rows: int, n_cols: int) -> np.ndarray:
    """(2 (n_rows-1)(n_cols-1), 3) vertex indices (row-major, index = i * n_cols + j) of the
    counter-clockwise (seen from +z) triangles that :func:`mesh_height` interpolates."""
    i, j = np.meshgrid(np.arange(n_rows - 1), np.arange(n_cols - 1), indexing="ij")
    a = (i * n_cols + j).ravel()
    b, c, d = a + 1, a + n_cols + 1, a + n_cols             # (i,j+1), (i+1,j+1), (i+1,j)
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def random_craters(rng: np.random.Generator, extent, n, r_min=0.5, r_max=8.0, slope=2.0,
                   depth_ratio=(0.2, 0.2)) -> tuple:
    """``n`` craters, uniform positions, power-law radii (differential density ~ r^-slope, so the
    cumulative count N(>r) ~ r^(1 - slope)) in [r_min, r_max]; depth/diameter uniform in ``depth_ratio``."""
    if not (0 < r_min < r_max) or slope <= 1:
        raise SceneError(f"craters: need 0 < r_min < r_max and slope > 1, got {r_min}, {r_max}, {slope}")
    xmin, xmax, ymin, ymax = extent
    u = rng.random(n)
    a = 1 - slope
    r = (r_min ** a + u * (r_max ** a - r_min ** a)) ** (1 / a)
    xs, ys = rng.uniform(xmin, xmax, n), rng.uniform(ymin, ymax, n)
    dr = rng.uniform(depth_ratio[0], depth_ratio[1], n)
    return tuple(Crater(float(px), float(py), float(pr), float(q)) for px, py, pr, q in zip(xs, ys, r, dr))


def power_law_slope(radii, r_min: float, r_max: float) -> float:
    """Maximum-likelihood differential exponent of radii drawn from ``~ r^-slope`` truncated to
    [r_min, r_max] (bisection on the score equation); the check of :func:`random_craters`."""
    r = np.asarray(radii, float)
    mean_log = np.log(r / r_min).mean()

    def expected_log(s):                         # E[log(r / r_min)] under the truncated power law
        a = 1 - s
        lo, hi = r_min ** a, r_max ** a
        return (hi * np.log(r_max / r_min)) / (hi - lo) - 1 / a

    lo, hi = 1.0 + 1e-6, 10.0
    for _ in range(80):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if expected_log(mid) > mean_log else (lo, mid)
    return (lo + hi) / 2


def random_rocks(rng: np.random.Generator, extent, n, a_min=0.1, a_max=0.6) -> tuple:
    """``n`` rocks ``(x, y, radius, height)`` with height 0.3-0.7 x radius."""
    xmin, xmax, ymin, ymax = extent
    a = rng.uniform(a_min, a_max, n)
    return tuple((float(px), float(py), float(pa), float(pa * h)) for px, py, pa, h in
                 zip(rng.uniform(xmin, xmax, n), rng.uniform(ymin, ymax, n), a, rng.uniform(0.3, 0.7, n)))
