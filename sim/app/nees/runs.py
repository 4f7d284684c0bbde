"""Monte-Carlo consistency runs (OpenVINS ov_eval style): render once, re-noise per run.

``vary="noise"`` (the default): the scenario is generated once with ``--ideal`` (noise-free images
and IMU); run ``k`` sees the same images with fresh image noise (stream ``image_noise`` of seed
``base_seed + k``) and fresh IMU noise (streams ``imu_white``/``imu_bias``), so runs differ only in
the noise. Error that the noise cannot move (each feature's rendering / tracking error in this one
sequence) is then common to all runs.

``vary="scene"`` (our extension): run ``k`` is also re-rendered with scenario seed
``seed + 1 + k`` (new procedural textures and clutter, new seeded vibration of the same route), so
that per-feature error is drawn afresh each run too; each run is scored against its own truth.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rigs.image_noise import ImageNoiseDataset
from rigs.records import ImuSamples
from sim.app.nees.scoring import ConsistencyResult, evaluate_runs
from sim.app.validation.truth_tracks import run_oracle
from sim.errors import SimError
from sim.rng import stream
from sim.scenarios import cached_dataset, get_scenario
from sim.sensors.imu_noise import add_imu_noise
from vo.dataset import open_dataset
from vo.errorprop.renoise import MIN_REPLICATES, renoise_covariance
from vo.errors import VoError
from vo.estimators.runner import run_estimator


class NoisyDataset(ImageNoiseDataset):
    """A reader-API dataset whose images (:class:`rigs.image_noise.ImageNoiseDataset`, stream
    ``seed``) and IMU get seeded noise on the fly. Delegates the rest."""

    def __init__(self, base, image_sigma: float, seed: int, imu_model=None):
        super().__init__(base, image_sigma, int(seed))
        self._seed = int(seed)
        self._imu_model = imu_model
        self._imu = None

    @property
    def imu(self):
        if self._imu_model is None or self._base.imu is None:
            return self._base.imu
        if self._imu is None:
            clean = self._base.imu
            noisy, _ = add_imu_noise(ImuSamples(clean.t_ns, clean.gyro, clean.accel), self._imu_model,
                                     stream(self._seed, "imu_white"), stream(self._seed, "imu_bias"))
            self._imu = ImuSamples(noisy.t_ns, noisy.gyro, noisy.accel)
        return self._imu


VARY = ("noise", "scene")


def _one_run(config, estimator: str, image_sigma: float, seed: int, options: dict, max_frames,
             oracle_px=None, renoise: int = 0) -> tuple:
    """One Monte-Carlo run on the (cached) ideal dataset of ``config`` ->
    ((n,4,4) poses, (n,6,6) covariances, (N,4,4) truth in O, (N,) t_s); a module function for workers.
    With ``oracle_px`` the run uses exact tracks + that iid pixel noise (:mod:`sim.app.validation.truth_tracks`).
    ``renoise`` > 0: the covariances are those of that many re-noised replicates of this run's images
    (:func:`vo.errorprop.renoise.renoise_covariance`, noise level estimated from the images) instead
    of the estimator's own."""
    base = open_dataset(cached_dataset(config, progress=False))
    gt = base.groundtruth_cam0()
    truth = (np.linalg.inv(gt.T[0]) @ gt.T, gt.t_s)
    noisy = NoisyDataset(base, image_sigma, seed, imu_model=base.rig.imu)      # the rig's Kalibr densities
    if oracle_px is None:
        frames = run_estimator(estimator, noisy, options=options, progress=False, max_frames=max_frames).frames
    else:
        frames = run_oracle(base, options, oracle_px, seed, max_frames=max_frames)
    T_est = np.array([f.T_o_c0 for f in frames])
    if renoise:
        rn = renoise_covariance(noisy, estimator, options, renoise, seed=seed, T_hat=T_est, max_frames=max_frames)
        return (T_est[:len(rn.cov)], rn.cov) + truth
    if any(f.cov is None for f in frames[1:]):
        raise VoError(f"estimator {estimator!r} reports no covariance; consistency needs FrameResult.cov "
                      f"(or --renoise R)")
    return (T_est, np.array([f.cov if f.cov is not None else np.eye(6) * 1e-12 for f in frames])) + truth


def _check(runs, vary, renoise, oracle_px, estimator) -> None:
    """One-line :class:`~sim.errors.SimError` for arguments :func:`consistency` cannot run with."""
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 2:
        raise SimError(f"consistency runs: {runs!r}; must be an integer >= 2")
    if vary not in VARY:
        raise SimError(f"consistency vary: {vary!r}; valid: {', '.join(VARY)}")
    if isinstance(renoise, bool) or not isinstance(renoise, (int, np.integer)) or renoise < 0 or \
            0 < renoise < MIN_REPLICATES or (renoise and oracle_px is not None):
        raise SimError(f"consistency renoise: {renoise!r}; must be 0 (off) or an integer >= {MIN_REPLICATES}, "
                       f"and not with oracle_px")
    if oracle_px is not None and (estimator != "rop" or not np.isfinite(oracle_px) or oracle_px < 0):
        raise SimError(f"consistency oracle_px: needs estimator 'rop' and a finite pixel sigma >= 0, "
                       f"got estimator {estimator!r}, oracle_px {oracle_px!r}")


def _run_all(args: list, workers: int, progress: bool, desc: str) -> list:
    """:func:`_one_run` for every argument tuple, in order; ``workers`` > 1: spawned processes."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from tqdm import tqdm
    out = []
    with tqdm(total=len(args), desc=desc, disable=not progress) as bar:
        if workers > 1:
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
                for f in [pool.submit(_one_run, *a) for a in args]:
                    out.append(f.result())
                    bar.update()
        else:
            for a in args:
                out.append(_one_run(*a))
                bar.update()
    return out


def consistency(scenario: str, estimator: str, runs: int = 30, image_sigma: float = 1.0, base_seed: int = 1000,
                options=None, progress: bool = True, max_frames=None, workers: int = 1,
                vary: str = "noise", oracle_px=None, overrides=(), renoise: int = 0) -> ConsistencyResult:
    """Run ``estimator`` on ``runs`` noise realisations of ``scenario``; NEES and drift-spread vs prediction.

    Run ``k`` re-noises the images with seed ``base_seed + k``; with ``vary="scene"`` it is also
    rendered from scenario seed ``seed + 1 + k`` (module docstring). ``workers`` > 1 runs them in
    that many processes (spawned; same results: every run is seeded on its own). ``oracle_px``
    (``rop`` only): exact track positions from depth and truth plus that iid pixel noise instead of
    the images' (:mod:`sim.app.validation.truth_tracks`; the scenario is rendered with depth).
    ``overrides``: scenario ``key=value`` overrides (as ``--set``, e.g. ``render.supersample=3``).
    ``renoise`` > 0: score the covariance of that many re-noised replicates per run instead of the
    estimator's own (:mod:`vo.errorprop.renoise`; (1 + renoise) x the run time)."""
    _check(runs, vary, renoise, oracle_px, estimator)
    ideal = replace(get_scenario(scenario, overrides=tuple(overrides)), ideal=True, depth=oracle_px is not None)
    configs = [ideal if vary == "noise" else replace(ideal, seed=ideal.seed + 1 + k) for k in range(runs)]
    if vary == "noise":
        cached_dataset(ideal, progress=progress)          # render once, before the workers start
    args = [(c, estimator, image_sigma, base_seed + k, options or {}, max_frames, oracle_px, renoise)
            for k, c in enumerate(configs)]
    out = _run_all(args, workers, progress, f"monte-carlo ({vary})")
    gt = out[0][2]
    if vary == "scene":                                  # one truth per run, cut to the shortest
        n = min(len(o[2]) for o in out)
        gt = np.array([o[2][:n] for o in out])
    described = vary if oracle_px is None else f"{vary}; oracle tracks, {oracle_px:g} px noise"
    if renoise:
        described += f"; covariance of {renoise} re-noised replicates"
    return evaluate_runs(scenario, estimator, gt, out[0][3], [o[0] for o in out], [o[1] for o in out],
                         vary=described, keep_runs=True)
