"""Normalised estimation error squared (NEES) and its chi-square bounds, as OpenVINS's ov_eval uses them.

For ``R`` Monte-Carlo runs of a ``d``-dimensional error ``e`` with claimed covariance ``P``,
``NEES = e^T P^-1 e``; a consistent estimator has ``E[NEES] = d``, and the run-averaged NEES times
``R`` is chi-square with ``R d`` degrees of freedom, so the two-sided 95% interval of the run
average is ``chi2.ppf([0.025, 0.975], R d) / R``.

That interval assumes the claimed ``P`` is exact. When ``P`` is itself a sample covariance of ``n``
draws (a bootstrap's replicates), even an estimator whose draws come from the true error distribution
scores higher: :func:`expected_nees_sample_cov` (Hotelling's T^2 mean) and
:func:`inside_fraction_sample_cov` give the ideal figures to compare a bootstrap covariance with.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from vo.errors import VoError


def nees(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``err`` (..., d), ``cov`` (..., d, d) -> NEES (...). A singular ``cov`` (a claimed zero variance,
    e.g. a bootstrap whose replicates all agree) gives ``inf`` where the error leaves its range, not an
    exception."""
    err = np.asarray(err, dtype=float)
    try:
        sol = np.linalg.solve(cov, err[..., None])[..., 0]
        return np.einsum("...i,...i->...", err, sol)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, -1, -2)))
        proj = np.einsum("...ji,...j->...i", V, err) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            terms = np.where(w > 1e-300, proj / np.where(w > 1e-300, w, 1.0), np.where(proj > 0, np.inf, 0.0))
        return terms.sum(axis=-1)


def chi2_interval(dof: int, runs: int, confidence: float = 0.95) -> tuple:
    """Two-sided interval of the run-averaged NEES of ``dof``-dimensional errors over ``runs`` runs."""
    a = (1 - confidence) / 2
    lo, hi = chi2.ppf([a, 1 - a], dof * runs)
    return float(lo / runs), float(hi / runs)


@dataclass(frozen=True)
class NeesSummary:
    mean_nees: np.ndarray        # (T,) run-averaged NEES per timestamp
    bounds: tuple                # (lo, hi)
    fraction_inside: float
    dof: int
    runs: int
    overall_mean: float

    def to_dict(self) -> dict:
        return {"fraction_inside": self.fraction_inside, "bounds": list(self.bounds), "dof": self.dof,
                "runs": self.runs, "overall_mean": self.overall_mean}


def summarize_nees(nees_runs: np.ndarray, dof: int, confidence: float = 0.95) -> NeesSummary:
    """``nees_runs`` (R, T) per run and timestamp -> run average, interval and fraction inside."""
    nees_runs = np.asarray(nees_runs, dtype=float)
    runs = nees_runs.shape[0]
    mean = nees_runs.mean(axis=0)
    lo, hi = chi2_interval(dof, runs, confidence)
    inside = float(np.mean((mean >= lo) & (mean <= hi))) if mean.size else 0.0
    return NeesSummary(mean, (lo, hi), inside, dof, runs, float(mean.mean()) if mean.size else float("nan"))


def nees_split(err: np.ndarray, cov: np.ndarray) -> tuple:
    """Split the run-averaged NEES into the error common to all runs and the run-to-run spread.

    ``err`` (R, T, d), ``cov`` (R, T, d, d) -> ``(bias (T,), spread (T,))`` with
    ``bias = m^T Pbar^-1 m`` (``m`` the run-mean error, ``Pbar`` the run-mean covariance) and
    ``spread = mean_r (e_r - m)^T P_r^-1 (e_r - m) * R / (R - 1)``. A consistent estimator whose
    runs share no error has ``E[bias] = d / R`` and ``E[spread] = d``; with equal ``P_r`` the NEES
    average is ``bias + spread (R - 1) / R`` exactly. Used to state how much of an NEES excess is
    error the noise realisations cannot move (one rendered sequence, fixed per-feature errors)."""
    err, cov = np.asarray(err, float), np.asarray(cov, float)
    runs = err.shape[0]
    m = err.mean(axis=0)
    bias = nees(m, cov.mean(axis=0))
    spread = nees(err - m[None], cov).mean(axis=0) * runs / max(runs - 1, 1)
    return bias, spread


def expected_nees_sample_cov(dof: int, n_samples: int) -> float:
    """``E[e^T S^-1 e]`` for ``e ~ N(0, P)`` and ``S`` an independent sample covariance (ddof 1) of
    ``n`` draws of ``N(0, P)``: ``e^T S^-1 e ~ d (n - 1) / (n - d) F(d, n - d)`` (Hotelling's T^2),
    whose mean is ``d (n - 1) / (n - d - 2)``; 3.34 for ``d = 3, n = 40``. Needs ``n > d + 2``."""
    if n_samples <= dof + 2:
        raise VoError(f"expected_nees_sample_cov.n_samples: {n_samples!r}; must exceed dof + 2 = {dof + 2}")
    return dof * (n_samples - 1) / (n_samples - dof - 2)


def inside_fraction_sample_cov(dof: int, n_samples: int, runs: int, rng: np.random.Generator,
                               trials: int = 4000, confidence: float = 0.95) -> float:
    """Monte-Carlo: the fraction of timestamps whose ``runs``-averaged NEES falls inside the chi-square
    interval (:func:`chi2_interval`) for an ideal estimator whose covariance is the sample covariance
    of ``n_samples`` exact draws (``trials`` independent timestamps). The best a bootstrap with that
    many replicates can score against the issue's interval."""
    lo, hi = chi2_interval(dof, runs, confidence)
    inside = 0
    for k in range(0, trials, 500):                     # chunks keep the (t, R, n, d) draws small
        t = min(500, trials - k)
        e = rng.standard_normal((t, runs, dof))
        z = rng.standard_normal((t, runs, n_samples, dof))
        z -= z.mean(axis=2, keepdims=True)
        mean = nees(e, np.einsum("trni,trnj->trij", z, z) / (n_samples - 1)).mean(axis=1)
        inside += int(np.sum((mean >= lo) & (mean <= hi)))
    return inside / trials
