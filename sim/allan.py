"""Overlapping Allan deviation and a fit of the white-noise / random-walk model.

For a rate signal x sampled at ``rate_hz`` with integral theta_k = sum_{j<k} x_j / rate, the
overlapping Allan variance at tau = m / rate is
``sigma^2(tau) = sum_k (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 / (2 tau^2 (N - 2m))``
(IEEE Std 952). White noise of density N gives ``N / sqrt(tau)``; a bias random walk of
density K gives ``K sqrt(tau / 3)``.
"""
from __future__ import annotations

import numpy as np

from sim.errors import SimError


def allan_deviation(x, rate_hz: float, taus) -> tuple:
    """x (N,) or (N,C) -> (taus_used (T,), adev (T,) or (T,C)).

    Each tau is rounded to a whole number of samples m >= 1 (duplicates removed); taus with
    2m >= N are dropped.
    """
    x = np.asarray(x, dtype=float)
    squeeze = x.ndim == 1
    x = x[:, None] if squeeze else x
    if x.ndim != 2 or x.shape[0] < 3 or not rate_hz > 0:
        raise SimError(f"allan_deviation: need x (N>=3,) or (N>=3,C) and rate_hz > 0, got {x.shape}, {rate_hz!r}")
    n = x.shape[0]
    ms = np.unique(np.maximum(1, np.round(np.asarray(taus, dtype=float) * rate_hz).astype(np.int64)))
    ms = ms[2 * ms < n]
    theta = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0) / rate_hz])
    out = np.empty((ms.size, x.shape[1]))
    for i, m in enumerate(ms):
        d = theta[2 * m:] - 2 * theta[m:-m] + theta[:-2 * m]
        tau = m / rate_hz
        out[i] = np.sqrt((d * d).sum(axis=0) / (2 * tau * tau * d.shape[0]))
    taus_used = ms / rate_hz
    return taus_used, (out[:, 0] if squeeze else out)


def fit_white_and_walk(taus, adev) -> tuple:
    """Least squares of adev^2 = N^2 / tau + K^2 tau / 3 (relative residuals) -> (N, K), one column."""
    taus, var = np.asarray(taus, dtype=float), np.asarray(adev, dtype=float) ** 2
    A = np.column_stack([1 / taus, taus / 3]) / var[:, None]
    coef, *_ = np.linalg.lstsq(A, np.ones_like(var), rcond=None)
    return float(np.sqrt(max(coef[0], 0.0))), float(np.sqrt(max(coef[1], 0.0)))


def loglog_slope(taus, adev, tau_min: float, tau_max: float) -> float:
    """Slope of log(adev) vs log(tau) fitted over tau_min <= tau <= tau_max (one column)."""
    taus, adev = np.asarray(taus, dtype=float), np.asarray(adev, dtype=float)
    sel = (taus >= tau_min) & (taus <= tau_max)
    if sel.sum() < 2:
        raise SimError(f"loglog_slope: fewer than two taus in [{tau_min}, {tau_max}]")
    return float(np.polyfit(np.log(taus[sel]), np.log(adev[sel]), 1)[0])


def density_at_1s(taus, adev) -> float:
    """ADEV at tau = 1 s (log-log interpolation): the white-noise density read off the plot."""
    return float(np.exp(np.interp(0.0, np.log(np.asarray(taus, float)), np.log(np.asarray(adev, float)))))
