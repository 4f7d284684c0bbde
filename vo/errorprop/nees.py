"""Normalised estimation error squared (NEES) and its chi-square bounds, as OpenVINS's ov_eval uses them.

For ``R`` Monte-Carlo runs of a ``d``-dimensional error ``e`` with claimed covariance ``P``,
``NEES = e^T P^-1 e``; a consistent estimator has ``E[NEES] = d``, and the run-averaged NEES times
``R`` is chi-square with ``R d`` degrees of freedom, so the two-sided 95% interval of the run
average is ``chi2.ppf([0.025, 0.975], R d) / R``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2


def nees(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``err`` (..., d), ``cov`` (..., d, d) -> NEES (...)."""
    err = np.asarray(err, dtype=float)
    sol = np.linalg.solve(cov, err[..., None])[..., 0]
    return np.einsum("...i,...i->...", err, sol)


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
