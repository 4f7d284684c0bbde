"""Monte-Carlo consistency runs (OpenVINS ov_eval style): render once, re-noise per run.

``vary="noise"`` (the default, the issue's design): the scenario is generated once with
``--ideal`` (noise-free images and IMU); run ``k`` sees the same images with fresh image noise
(stream ``image_noise`` of seed ``base_seed + k``) and fresh IMU noise (streams
``imu_white``/``imu_bias``), so runs differ only in the noise. Error that the noise cannot move
(each feature's rendering / tracking error in this one sequence) is then common to all runs.

``vary="scene"`` (our extension): run ``k`` is also re-rendered with scenario seed
``seed + 1 + k`` (new procedural textures and clutter, new seeded vibration of the same route), so
that per-feature error is drawn afresh each run too; each run is scored against its own truth.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from sim.rng import stream
from vo.dataset.image_noise import ImageNoiseDataset


class NoisyDataset(ImageNoiseDataset):
    """A reader-API dataset whose images (:class:`vo.dataset.image_noise.ImageNoiseDataset`, stream
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
            from sim.imu import ImuSamples
            from sim.imu_noise import add_imu_noise
            from vo.dataset.types import ImuData
            clean = self._base.imu
            noisy, _ = add_imu_noise(ImuSamples(clean.t_ns, clean.gyro, clean.accel), self._imu_model,
                                     stream(self._seed, "imu_white"), stream(self._seed, "imu_bias"))
            self._imu = ImuData(noisy.t_ns, noisy.gyro, noisy.accel)
        return self._imu


def pose_errors(gt_T_o_c0: np.ndarray, est_T_o_c0: np.ndarray) -> tuple:
    """(N,4,4) truth and estimate -> rotation errors (N,3) ``log(R_true R_est^T)`` (left perturbation,
    as FrameResult.cov defines it) and position errors (N,3) ``p_true - p_est``."""
    from rigs.geometry import pose_error_left
    e = pose_error_left(gt_T_o_c0, est_T_o_c0)
    return e[:, :3], e[:, 3:]


def truth_per_run(T_true, runs: int) -> np.ndarray:
    """(R,N,4,4) truth: ``T_true`` (N,4,4) shared by all runs (``vary="noise"``) or already (R,N,4,4)."""
    T_true = np.asarray(T_true)
    return np.broadcast_to(T_true[None], (runs,) + T_true.shape) if T_true.ndim == 3 else T_true


def end_errors(runs_data: dict) -> tuple:
    """Per-run error of the last pose, ``runs_data`` as :func:`consistency` fills it (or ``runs.npz``):
    rotation (R,3) rad and position (R,3) m, left perturbation in the frame of each run's first true
    camera pose (x right, y down, z forward)."""
    T_est = runs_data["T_est"]
    rot, pos = [], []
    for T_t, T_e in zip(truth_per_run(runs_data["T_true"], len(T_est)), T_est):
        n = min(len(T_t), len(T_e))
        e_rot, e_pos = pose_errors(np.linalg.inv(T_t[0]) @ T_t[:n], np.asarray(T_e)[:n])
        rot.append(e_rot[-1])
        pos.append(e_pos[-1])
    return np.array(rot), np.array(pos)


@dataclass
class ConsistencyResult:
    scenario: str
    estimator: str
    runs: int
    t_s: np.ndarray = field(repr=False)
    distance_m: np.ndarray = field(repr=False)
    nees_pos: object = None            # vo.errorprop.NeesSummary
    nees_rot: object = None
    predicted_std_m: np.ndarray = field(default=None, repr=False)   # sqrt(trace P_pos), run-averaged
    measured_std_m: np.ndarray = field(default=None, repr=False)    # sqrt(trace of the sample covariance)
    n_frames_used: int = 0
    scored: np.ndarray = field(default=None, repr=False)             # indices of the scored timestamps
    mean_error_m: np.ndarray = field(default=None, repr=False)      # |run-mean position error| (common to all runs)
    split_pos: tuple = None      # (bias, spread) means over the scored timestamps, vo.errorprop.nees.nees_split
    split_rot: tuple = None
    vary: str = "noise"          # what changes between runs (module docstring)
    runs_data: dict = field(default=None, repr=False)   # per-run poses / covariances (consistency() fills it)

    def end_ratio(self) -> float:
        return float(self.measured_std_m[-1] / self.predicted_std_m[-1])

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "estimator": self.estimator, "runs": self.runs, "vary": self.vary,
                "nees_position": self.nees_pos.to_dict(), "nees_attitude": self.nees_rot.to_dict(),
                "end_predicted_std_m": float(self.predicted_std_m[-1]),
                "end_measured_std_m": float(self.measured_std_m[-1]),
                "end_measured_over_predicted": self.end_ratio(), "n_frames_used": self.n_frames_used,
                "nees_position_bias_spread": list(self.split_pos), "nees_attitude_bias_spread": list(self.split_rot),
                "path_length_m": float(self.distance_m[-1])}

    def text(self) -> str:
        p, r = self.nees_pos, self.nees_rot
        return "\n".join([
            f"consistency of {self.estimator} on {self.scenario}: {self.runs} runs (vary {self.vary}), "
            f"{self.n_frames_used} timestamps",
            f"  position NEES: mean {p.overall_mean:.2f} (dof 3; mean/3 = {p.overall_mean / 3:.2f}), inside 95% interval [{p.bounds[0]:.2f}, "
            f"{p.bounds[1]:.2f}] at {100 * p.fraction_inside:.1f}% of timestamps",
            f"  attitude NEES: mean {r.overall_mean:.2f} (dof 3; mean/3 = {r.overall_mean / 3:.2f}), inside at {100 * r.fraction_inside:.1f}% of timestamps",
            f"  NEES split (common error over runs / run-to-run spread, expected {3 / self.runs:.2f} / 3): position "
            f"{self.split_pos[0]:.2f} / {self.split_pos[1]:.2f}, attitude {self.split_rot[0]:.2f} / {self.split_rot[1]:.2f}",
            f"  end-point error std: predicted {self.predicted_std_m[-1]:.4f} m, measured {self.measured_std_m[-1]:.4f} m"
            f" (ratio {self.end_ratio():.2f}) after {self.distance_m[-1]:.1f} m",
        ])


MIN_DISTANCE_M = 0.05   # timestamps before the cart has moved this far are not scored (see evaluate_runs)


def evaluate_runs(scenario: str, estimator: str, gt_T_o_c0: np.ndarray, t_s: np.ndarray, est_T: list, covs: list,
                  min_distance_m: float = MIN_DISTANCE_M) -> ConsistencyResult:
    """NEES and spread from ``runs`` estimates: ``gt_T_o_c0`` (N,4,4) truth in the estimator's frame O
    (or (R,N,4,4), one per run; distance is measured along run 0's),
    ``est_T`` / ``covs`` lists (one per run) of (n_k,4,4) poses and (n_k,6,6) covariances of
    ``[rotvec, position]`` of ``T_o_c0`` as the estimator reported them (runs are cut to the shortest).

    Timestamps before the truth has moved ``min_distance_m`` are not scored: the first pose is the
    anchor (zero error, zero covariance), and while the cart stands still a VO that detects
    standstill (rop's rotation-only epochs) returns the exact zero translation, so the NEES is ~0
    by construction and says nothing about the covariance."""
    n = min(len(e) for e in est_T)
    T_est = np.array([np.asarray(e)[:n] for e in est_T])
    P = np.array([np.asarray(c)[:n] for c in covs])
    gt = truth_per_run(gt_T_o_c0, len(T_est))                                         # (R, N, 4, 4)
    errs = [pose_errors(g[:n], T) for g, T in zip(gt, T_est)]
    e_rot, e_pos = np.array([e[0] for e in errs]), np.array([e[1] for e in errs])
    from vo.errorprop.nees import nees, nees_split, summarize_nees
    dist = np.r_[0, np.cumsum(np.linalg.norm(np.diff(gt[0, :n, :3, 3], axis=0), axis=1))]
    sl = np.flatnonzero(dist >= max(min_distance_m, 1e-12))
    ne_pos = nees(e_pos[:, sl], P[:, sl, 3:, 3:])
    ne_rot = nees(e_rot[:, sl], P[:, sl, :3, :3])
    pred = np.sqrt(np.trace(P[:, :, 3:, 3:], axis1=2, axis2=3).mean(axis=0))
    meas = np.sqrt(np.array([np.trace(np.cov(e_pos[:, t].T)) for t in range(n)]))
    res = ConsistencyResult(scenario, estimator, len(T_est), np.asarray(t_s)[:n], dist, summarize_nees(ne_pos, 3),
                            summarize_nees(ne_rot, 3), pred, meas, len(sl))
    res.scored = sl
    res.mean_error_m = np.linalg.norm(e_pos.mean(axis=0), axis=1)
    res.split_pos = tuple(float(np.mean(x)) for x in nees_split(e_pos[:, sl], P[:, sl, 3:, 3:]))
    res.split_rot = tuple(float(np.mean(x)) for x in nees_split(e_rot[:, sl], P[:, sl, :3, :3]))
    return res


VARY = ("noise", "scene")


def _one_run(config, estimator: str, image_sigma: float, seed: int, options: dict, max_frames,
             oracle_px=None, renoise: int = 0) -> tuple:
    """One Monte-Carlo run on the (cached) ideal dataset of ``config`` ->
    ((n,4,4) poses, (n,6,6) covariances, (N,4,4) truth in O, (N,) t_s); a module function for workers.
    With ``oracle_px`` the run uses exact tracks + that iid pixel noise (:mod:`sim.app.validation.oracle_tracks`).
    ``renoise`` > 0: the covariances are those of that many re-noised replicates of this run's images
    (:func:`vo.errorprop.renoise.renoise_covariance`, noise level estimated from the images) instead
    of the estimator's own."""
    from sim.scenarios import cached_dataset
    from vo.dataset import open_dataset
    from vo.estimators.runner import run_estimator
    from vo.errors import VoError
    base = open_dataset(cached_dataset(config, progress=False))
    gt = base.groundtruth_cam0()
    truth = (np.linalg.inv(gt.T[0]) @ gt.T, gt.t_s)
    noisy = NoisyDataset(base, image_sigma, seed, imu_model=None)
    if oracle_px is None:
        frames = run_estimator(estimator, noisy, options=options, progress=False, max_frames=max_frames).frames
    else:
        from sim.app.validation.oracle_tracks import run_oracle
        frames = run_oracle(base, options, oracle_px, seed, max_frames=max_frames)
    T_est = np.array([f.T_o_c0 for f in frames])
    if renoise:
        from vo.errorprop.renoise import renoise_covariance
        rn = renoise_covariance(noisy, estimator, options, renoise, seed=seed, T_hat=T_est, max_frames=max_frames)
        return (T_est[:len(rn.cov)], rn.cov) + truth
    if any(f.cov is None for f in frames[1:]):
        raise VoError(f"estimator {estimator!r} reports no covariance; consistency needs FrameResult.cov "
                      f"(or --renoise R)")
    return (T_est, np.array([f.cov if f.cov is not None else np.eye(6) * 1e-12 for f in frames])) + truth


def consistency(scenario: str, estimator: str, runs: int = 30, image_sigma: float = 1.0, base_seed: int = 1000,
                options=None, progress: bool = True, max_frames=None, workers: int = 1,
                vary: str = "noise", oracle_px=None, overrides=(), renoise: int = 0) -> ConsistencyResult:
    """Run ``estimator`` on ``runs`` noise realisations of ``scenario``; NEES and drift-spread vs prediction.

    Run ``k`` re-noises the images with seed ``base_seed + k``; with ``vary="scene"`` it is also
    rendered from scenario seed ``seed + 1 + k`` (module docstring). ``workers`` > 1 runs them in
    that many processes (spawned; same results: every run is seeded on its own). ``oracle_px``
    (``rop`` only): exact track positions from depth and truth plus that iid pixel noise instead of
    the images' (:mod:`sim.app.validation.oracle_tracks`; the scenario is rendered with depth).
    ``overrides``: scenario ``key=value`` overrides (as ``--set``, e.g. ``render.supersample=3``).
    ``renoise`` > 0: score the covariance of that many re-noised replicates per run instead of the
    estimator's own (:mod:`vo.errorprop.renoise`; (1 + renoise) x the run time)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from tqdm import tqdm
    from sim.errors import SimError
    from sim.scenarios import cached_dataset, get_scenario

    if vary not in VARY:
        raise SimError(f"consistency vary: {vary!r}; valid: {', '.join(VARY)}")
    from vo.errorprop.renoise import MIN_REPLICATES
    if isinstance(renoise, bool) or not isinstance(renoise, (int, np.integer)) or renoise < 0 or \
            0 < renoise < MIN_REPLICATES or (renoise and oracle_px is not None):
        raise SimError(f"consistency renoise: {renoise!r}; must be 0 (off) or an integer >= {MIN_REPLICATES}, "
                       f"and not with oracle_px")
    if oracle_px is not None and (estimator != "rop" or not np.isfinite(oracle_px) or oracle_px < 0):
        raise SimError(f"consistency oracle_px: needs estimator 'rop' and a finite pixel sigma >= 0, "
                       f"got estimator {estimator!r}, oracle_px {oracle_px!r}")
    ideal = replace(get_scenario(scenario, overrides=tuple(overrides)), ideal=True, depth=oracle_px is not None)
    configs = [ideal if vary == "noise" else replace(ideal, seed=ideal.seed + 1 + k) for k in range(runs)]
    if vary == "noise":
        cached_dataset(ideal, progress=progress)          # render once, before the workers start
    args = [(c, estimator, image_sigma, base_seed + k, options or {}, max_frames, oracle_px, renoise)
            for k, c in enumerate(configs)]
    bar = tqdm(total=runs, desc=f"monte-carlo ({vary})", disable=not progress)
    out = []
    if workers > 1:
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            for f in [pool.submit(_one_run, *a) for a in args]:
                out.append(f.result())
                bar.update()
    else:
        for a in args:
            out.append(_one_run(*a))
            bar.update()
    bar.close()
    gt = out[0][2]
    if vary == "scene":                                  # one truth per run, cut to the shortest
        n = min(len(o[2]) for o in out)
        gt = np.array([o[2][:n] for o in out])
    res = evaluate_runs(scenario, estimator, gt, out[0][3], [o[0] for o in out], [o[1] for o in out])
    res.vary = vary if oracle_px is None else f"{vary}; oracle tracks, {oracle_px:g} px noise"
    if renoise:
        res.vary += f"; covariance of {renoise} re-noised replicates"
    res.runs_data = dict(T_true=gt, t_s=out[0][3], T_est=np.array([o[0] for o in out]),
                         cov=np.array([o[1] for o in out]))
    return res


def plot_consistency(res: ConsistencyResult, path) -> None:
    """NEES per timestamp with the 95% band, and predicted vs measured error spread against distance."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    d = res.distance_m[res.scored] if res.scored is not None else res.distance_m[1:]
    for s, label, c in ((res.nees_pos, "position", "b"), (res.nees_rot, "attitude", "g")):
        axes[0].plot(d, s.mean_nees, c, label=f"{label} ({100 * s.fraction_inside:.0f}% inside)")
    lo, hi = res.nees_pos.bounds
    axes[0].axhspan(lo, hi, color="k", alpha=0.12, label="95% interval")
    axes[0].set_yscale("log")
    axes[0].set_xlabel("distance travelled (m)")
    axes[0].set_ylabel(f"NEES averaged over {res.runs} runs")
    axes[0].legend(fontsize=8)
    source = "re-noised replicates" if "re-noised" in res.vary else "estimator's covariance"
    axes[1].plot(res.distance_m, res.predicted_std_m, "k-", label=f"predicted ({source})")
    axes[1].plot(res.distance_m, res.measured_std_m, "r.", ms=3, label="Monte-Carlo spread")
    if res.mean_error_m is not None:
        axes[1].plot(res.distance_m, res.mean_error_m, "c--", lw=1, label="|run-mean error| (common to all runs)")
    axes[1].set_xlabel("distance travelled (m)")
    axes[1].set_ylabel("position error (m)")
    axes[1].legend(fontsize=8)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{res.estimator} on {res.scenario}, {res.runs} runs, vary {res.vary}")
    from vo.eval.plots import save_figure
    save_figure(fig, path)


def save_npz_atomic(path, arrays: dict) -> None:
    """``np.savez_compressed`` to a temporary file in the same folder, then an atomic rename: an
    interrupted write never leaves a truncated ``path``."""
    import os
    from pathlib import Path
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)
