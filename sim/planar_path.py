"""The route's planar curve: a quintic spline through the waypoints (or their Gaussian-smoothed
polyline) and its arc-length parametrisation (used by :class:`sim.motion.VehicleTrajectory`; the
construction is described in :mod:`sim.motion`).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import make_interp_spline

from sim.errors import SimError

_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)


def smoothed_polyline(xy: np.ndarray, closed: bool, sigma_m: float) -> np.ndarray:
    """Polyline (M,2) (closed: last == first) -> dense points every ~sigma/5 after a Gaussian of
    std ``sigma_m`` (arc length). Straight runs stay straight; corners are rounded over ~2 sigma.
    Open ends use point-reflection padding, so the end points stay fixed."""
    from scipy.ndimage import gaussian_filter1d
    seg = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    ds = sigma_m / 5
    n = max(8, int(math.ceil(arc[-1] / ds)))
    a = np.linspace(0, arc[-1], n + 1)
    pts = np.column_stack([np.interp(a, arc, xy[:, 0]), np.interp(a, arc, xy[:, 1])])
    sig = sigma_m / (arc[-1] / n)
    if closed:
        out = gaussian_filter1d(pts[:-1], sig, axis=0, mode="wrap")
        return np.vstack([out, out[:1]])
    pad = min(n, int(4 * sig) + 1)
    padded = np.vstack([2 * pts[0] - pts[pad:0:-1], pts, 2 * pts[-1] - pts[-2:-pad - 2:-1]])
    return gaussian_filter1d(padded, sig, axis=0, mode="nearest")[pad:pad + n + 1]


def chord_spline(route, smoothing_m: float = 0.0):
    """Quintic spline c(u) (2-D) through the waypoints (or the smoothed polyline), u = chord length."""
    xy = route.xy
    if route.closed and not np.allclose(xy[0], xy[-1]):
        xy = np.vstack([xy, xy[:1]])
    keep = np.r_[True, np.linalg.norm(np.diff(xy, axis=0), axis=1) > 1e-9]
    xy = xy[keep]
    if xy.shape[0] < (4 if route.closed else 2):
        raise SimError(f"route.waypoints_xy: need at least {3 if route.closed else 2} distinct points, got {xy.shape[0]}")
    if smoothing_m > 0:
        xy = smoothed_polyline(xy, route.closed, smoothing_m)
    u = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))]
    if route.closed:
        if xy.shape[0] < 7:                       # periodic quintic needs >= 6 intervals
            u_f = np.linspace(0, u[-1], 7 * (xy.shape[0] - 1) + 1)
            xy = make_interp_spline(u, xy, k=3, bc_type="periodic")(u_f)
            u = u_f
        return make_interp_spline(u, xy, k=5, bc_type="periodic"), u
    if xy.shape[0] < 6:                           # natural quintic needs >= 6 points: densify
        k = min(3, xy.shape[0] - 1)
        u_f = np.linspace(0, u[-1], 5 * (xy.shape[0] - 1) + 1)
        xy = make_interp_spline(u, xy, k=k, bc_type="natural" if k == 3 else None)(u_f)
        u = u_f
    nat = [(3, np.zeros(2)), (4, np.zeros(2))]
    return make_interp_spline(u, xy, k=5, bc_type=(nat, nat)), u


def arc_length_table(c, u_knots: np.ndarray):
    """Fine grid u_f and cumulative arc length S(u_f) by 16-point Gauss-Legendre per cell."""
    per_span = 16 if u_knots.size < 200 else 2
    u_f = np.unique(np.concatenate([np.linspace(a, b, per_span + 1) for a, b in zip(u_knots[:-1], u_knots[1:])]))
    return u_f, np.r_[0.0, np.cumsum(gl_length(c.derivative(), u_f[:-1], u_f[1:]))]


def gl_length(dc, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Arc length of c over [a, b] (arrays), Gauss-Legendre."""
    half = (b - a)[:, None] / 2
    uu = (a[:, None] + half * (_GL_X + 1)).ravel()
    sp = np.linalg.norm(dc(uu), axis=1).reshape(half.shape[0], -1)
    return (sp * _GL_W).sum(axis=1) * half[:, 0]


def u_at_arclength(c, u_f, S_f, s: np.ndarray) -> np.ndarray:
    """Invert S(u) = s by Newton from the table bracket (converges to ~1e-13 m)."""
    dc = c.derivative()
    i = np.clip(np.searchsorted(S_f, s, side="right") - 1, 0, u_f.size - 2)
    u = u_f[i] + (s - S_f[i]) / (S_f[i + 1] - S_f[i]) * (u_f[i + 1] - u_f[i])
    for _ in range(6):
        S = S_f[i] + gl_length(dc, u_f[i], u)
        u = np.clip(u - (S - s) / np.linalg.norm(dc(u), axis=1), u_f[i], u_f[i + 1])
    return u
