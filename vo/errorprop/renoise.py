"""Image-noise propagation through a whole estimator, from one recording: re-noise and re-run.

What it predicts: the run-to-run spread of an estimator's poses when only the image noise changes
(the Monte-Carlo protocol that renders once and re-noises per run), from the one recording at hand.
Replicate ``r`` runs the estimator on the recording plus fresh i.i.d. grey-level noise of the
recording's own level ``sigma`` (:func:`vo.frontend.noise_level.estimate_noise_sigma` on the first
left image unless given); the covariance at each timestamp is that of the replicates' left
perturbations ``[rotvec, position]`` about the estimate from the recording (the convention of
``FrameResult.cov``), about the replicates' mean, ddof 1.

Why re-noising gives the run-to-run spread: a replicate differs from the recording by noise of std
``sigma``, so two replicates differ by ``sqrt(2) sigma`` - as two runs do. To first order (the LK
noise footprints) the replicates' spread is then the runs'; and every discrete decision (a corner
chosen in a grid cell, a forward-backward or epipolar check, a RANSAC inlier) flips between
replicates about as often as between runs, since it flips on a difference of the same size. On
rendered scenes those flips set most of the noise-only spread, and no first-order model sees them
(docs/studies/rop_consistency.md). It works for any estimator the runner can run (``name``, ``module:Class``),
at ``replicates`` times the cost of one run.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rigs.geometry import pose_error_cov
from rigs.image import to_gray
from rigs.image_noise import ImageNoiseDataset
from vo.errors import VoError
from vo.estimators.registry import is_external
from vo.estimators.runner import run_estimator
from vo.frontend.noise_level import estimate_noise_sigma

RENOISE_TAG = 0x5E1F              # separates the replicates' noise streams from the Monte-Carlo runs'
MIN_REPLICATES = 3


@dataclass
class RenoiseResult:
    """``t_ns`` (N,); ``T_hat`` (N,4,4) the estimate from the recording; ``T_reps`` (R,N,4,4) the
    replicates' (cut to the shortest run); ``cov`` (N,6,6) of ``[rotvec, position]``; ``sigma`` the
    noise level used (grey levels)."""

    t_ns: np.ndarray = field(repr=False)
    T_hat: np.ndarray = field(repr=False)
    T_reps: np.ndarray = field(repr=False)
    cov: np.ndarray = field(repr=False)
    sigma: float = 0.0

    @property
    def position_std_m(self) -> np.ndarray:
        """(N,) sqrt(trace) of each position covariance (m)."""
        return np.sqrt(np.trace(self.cov[:, 3:, 3:], axis1=1, axis2=2))

    @property
    def end_position_std_m(self) -> float:
        """sqrt(trace) of the last position covariance (m)."""
        return float(self.position_std_m[-1])

    @property
    def distance_m(self) -> np.ndarray:
        """(N,) distance travelled along the estimate from the recording (m)."""
        step = np.linalg.norm(np.diff(self.T_hat[:, :3, 3], axis=0), axis=1)
        return np.r_[0.0, np.cumsum(step)]

    def to_dict(self) -> dict:
        return {"sigma": self.sigma, "replicates": int(len(self.T_reps)), "n_frames": int(len(self.t_ns)),
                "distance_m": float(self.distance_m[-1]), "end_position_std_m": self.end_position_std_m,
                "end_rotation_std_deg": float(np.degrees(np.sqrt(np.trace(self.cov[-1, :3, :3]))))}

    def text(self) -> str:
        d = self.to_dict()
        return (f"re-noised replicates: {d['replicates']} at sigma {d['sigma']:.2f} grey levels, {d['n_frames']} frames, "
                f"{d['distance_m']:.2f} m: predicted end-point std {1e3 * d['end_position_std_m']:.2f} mm "
                f"(position), {d['end_rotation_std_deg']:.4f} deg (attitude)")

    def plot(self, path) -> None:
        """Predicted position std against distance (PNG)."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot(self.distance_m, 1e3 * self.position_std_m, "k-")
        ax.set_xlabel("distance travelled (m)")
        ax.set_ylabel("predicted position std (mm)")
        ax.set_title(f"{len(self.T_reps)} re-noised replicates, sigma {self.sigma:.2f}")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


def renoise_covariance(dataset, estimator: str, options: dict | None = None, replicates: int = 10,
                       sigma: float | None = None, seed: int = 0, T_hat: np.ndarray | None = None,
                       max_frames: int | None = None) -> RenoiseResult:
    """Run ``estimator`` on ``replicates`` re-noised copies of ``dataset`` (module docstring).

    ``seed`` names the replicates' noise streams (replicate ``r``: key ``(seed, r)``); ``T_hat``
    (N,4,4) the estimate from the recording if already computed (else it is run once more)."""
    if is_external(estimator):
        raise VoError(f"renoise estimator {estimator!r}: external commands read the dataset folder, not the "
                      f"re-noised images; use a registered name or 'package.module:Class'")
    if isinstance(replicates, bool) or not isinstance(replicates, (int, np.integer)) or replicates < MIN_REPLICATES:
        raise VoError(f"renoise replicates: {replicates!r}; must be an integer >= {MIN_REPLICATES}")
    if sigma is None:
        sigma = estimate_noise_sigma(to_gray(dataset.frame(0).left))
    run = dict(options=options, progress=False, max_frames=max_frames)
    if T_hat is None:
        T_hat = run_estimator(estimator, dataset, **run).trajectory.T
    reps = [run_estimator(estimator, ImageNoiseDataset(dataset, sigma, (seed, r), RENOISE_TAG), **run)
            for r in range(int(replicates))]
    n = min([len(T_hat)] + [len(r.trajectory) for r in reps])
    T_reps = np.array([r.trajectory.T[:n] for r in reps])
    t_ns = reps[0].trajectory.t_ns[:n]
    return RenoiseResult(t_ns, np.asarray(T_hat)[:n], T_reps, pose_error_cov(T_reps, np.asarray(T_hat)[:n]), float(sigma))
