"""Estimator benchmark on recorded datasets (real KITTI odometry sequences, real EuRoC folders, or ours):
per estimator and recording the end drift, ATE, RPE, KITTI devkit segment errors where the route is long
enough, ms per frame, frames by status, and one trajectory plot per recording.

Every recording is opened with :func:`vo.dataset.open_dataset` (its layout decides the reader) and evaluated
with the project's one evaluation (:func:`vo.eval.evaluate`, anchored at the true first pose: ``align
first``), so a real recording is scored exactly as a simulated one.

A recording is one draw of its sensor noise, and on a short one a few matches can decide the drift. With
``noise_draws`` N each estimator also runs on N copies of each recording with Gaussian image noise of
``noise_sigma`` grey levels added (:class:`rigs.image_noise.ImageNoiseDataset`, draw ``k`` the stream
``(k, frame index, REAL_DRAW_TAG)``: the same noise for every estimator, so their draws are paired), and
the row gives the drift of every draw: whether a difference between two figures exceeds what the noise
alone moves them.

With ``stride`` N every recording is read at 1/N of its frame rate (:class:`vo.dataset.frame_stride.FrameStride`:
every Nth frame, N times the motion between frames, as a faster drive or a slower camera would give); the
recording's label then ends in ``-strideN``.
"""
from __future__ import annotations

import re
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from rigs.image_noise import REAL_DRAW_TAG, ImageNoiseDataset
from sim.errors import SimError
from vo.dataset import open_dataset
from vo.dataset.frame_stride import FrameStride, valid_step
from vo.errors import DatasetError
from vo.estimators.registry import check_spec
from vo.estimators.runner import CPU_STAGE
from vo.eval.kitti_segments import KITTI_LENGTHS_M, kitti_errors
from vo.pipeline import prepare_out_dir, run_and_evaluate

DEFAULT_ESTIMATORS = ("rop", "klt-pnp")
DEFAULT_NOISE_SIGMA = 0.5     # grey levels added per draw: the low end of a real camera's own (KITTI excerpt: 0.46-1.25)


@dataclass
class RealBenchRow:
    """One estimator on one recording. ``kitti_*`` are the devkit segment errors over the devkit lengths
    (100-800 m) that fit in the route, NaN (``kitti_segments`` 0) on a route shorter than 100 m;
    ``rpe_*`` frame-to-frame RMSE; ``status_counts`` frames by estimator status; ``drift_draws_pct`` the drift
    of each noise draw (module docstring; empty without draws), ``noise_sigma`` their added noise (grey levels)."""

    recording: str
    estimator: str
    n_frames: int
    path_length_m: float
    drift_pct: float
    end_diff_m: float
    est_length_m: float
    ate_rmse_m: float
    rpe_trans_rmse_m: float
    rpe_rot_rmse_deg: float
    kitti_t_err_pct: float
    kitti_r_err_deg_per_100m: float
    kitti_segments: int
    ms_per_frame: float
    status_counts: dict = field(default_factory=dict)
    plot: str = ""
    cpu_ms_per_frame: float = float("nan")   # CPU ms of the estimator's calls (the runner's ``cpu`` stage)
    noise_sigma: float = 0.0
    drift_draws_pct: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return asdict(self)


def recording_name(dataset) -> str:
    """A short, file-name-safe label: ``<parent>-<folder>`` of the dataset path (``kitti_turn-00``)."""
    p = Path(dataset.path)
    raw = f"{p.parent.parent.name}-{p.name}" if p.parent.name == "sequences" else f"{p.parent.name}-{p.name}"
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", raw).strip("_") or "recording"


def segment_errors(gt, est) -> tuple:
    """Devkit segment errors over the devkit lengths within the route -> ``(t_err %, r_err deg/100 m, n)``;
    ``(nan, nan, 0)`` below 100 m (a shorter route has no devkit segment)."""
    length = gt.path_length
    lengths = tuple(v for v in KITTI_LENGTHS_M if v <= length)
    if not lengths:
        return float("nan"), float("nan"), 0
    k = kitti_errors(gt, est, lengths=lengths)
    return float(k.t_err_pct), float(100.0 * k.r_err_deg_per_m), int(k.n_segments)


def row_of(recording: str, name: str, res) -> RealBenchRow:
    """The row of one :func:`vo.pipeline.run_and_evaluate` result."""
    ev, run = res.evaluation, res.run
    counts: dict = {}
    for f in run.frames:
        counts[f.status] = counts.get(f.status, 0) + 1
    t_err, r_err, n_seg = segment_errors(ev.gt_matched, ev.aligned_est)
    total = run.timings_ms.get("total", float("nan"))
    return RealBenchRow(recording, name, len(run.frames), float(ev.drift.gt_length_m), float(ev.drift.drift_ratio_pct),
                        float(ev.drift.end_diff_m), float(ev.drift.est_length_m), float(ev.ape.trans.rmse),
                        float(ev.rpe_frame.trans.rmse), float(ev.rpe_frame.rot_deg.rmse), t_err, r_err, n_seg,
                        float(total), counts, cpu_ms_per_frame=float(run.timings_ms.get(CPU_STAGE, float("nan"))))


def ground_axes(positions: np.ndarray) -> tuple:
    """The two axes of largest extent of (N,3) positions (KITTI camera frame: x, z; EuRoC world: x, y)."""
    ext = np.ptp(positions, axis=0) if len(positions) else np.zeros(3)
    a, b = sorted(np.argsort(ext)[-2:])
    return int(a), int(b)


def plot_recording(recording: str, gt, estimates: dict, path) -> Path:
    """Top view of the ground truth (black) and every estimate (name -> aligned Trajectory) on the ground
    plane (:func:`ground_axes` of the truth), start marked."""
    from vo.eval.plots import plt, save_figure
    a, b = ground_axes(gt.positions)
    names = "xyz"
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(gt.positions[:, a], gt.positions[:, b], "k-", lw=1.8, label="ground truth")
    ax.plot(gt.positions[:1, a], gt.positions[:1, b], "ko", ms=5)
    for name, est in estimates.items():
        ax.plot(est.positions[:, a], est.positions[:, b], lw=1.2, label=name)
    ax.set_xlabel(f"{names[a]} (m)")
    ax.set_ylabel(f"{names[b]} (m)")
    ax.set_title(recording)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return save_figure(fig, path)


def bench_real(datasets, estimators=DEFAULT_ESTIMATORS, out_dir=None, one_core: bool = True, progress: bool = True,
               max_frames=None, options=None, noise_draws: int = 0, noise_sigma: float | None = None,
               stride: int = 1) -> list:
    """Run every estimator on every recording -> list of :class:`RealBenchRow`; with ``out_dir`` one
    ``<recording>_trajectory.png`` per recording there; with ``noise_draws`` also on that many re-noised copies
    (module docstring); with ``stride`` N > 1 on every Nth frame of each. A recording without ground truth is
    refused (:class:`vo.errors.DatasetError` naming it) before anything runs, as are a negative ``noise_draws``,
    draws without positive ``noise_sigma`` (None: :data:`DEFAULT_NOISE_SIGMA`) and a ``stride`` below 1."""
    import cv2

    noise_sigma = _noise_sigma(noise_draws, DEFAULT_NOISE_SIGMA if noise_sigma is None else noise_sigma)
    if not valid_step(stride):
        raise SimError(f"bench real: stride {stride!r}; must be an integer >= 1")
    for name in estimators:
        check_spec(name)
    opened = []
    for d in datasets:
        ds = open_dataset(d)
        if ds.groundtruth is None:
            raise DatasetError(f"{ds.path}: no ground truth (poses/NN.txt or state_groundtruth_estimate0); "
                               f"bench real needs it")
        opened.append(FrameStride(ds, stride) if stride > 1 else ds)
    out = prepare_out_dir(out_dir) if out_dir is not None else None
    if one_core:
        cv2.setNumThreads(1)
    rows, used = [], set()
    for ds in opened:
        rec = recording_name(ds) + (f"-stride{stride}" if stride > 1 else "")
        while rec in used:
            rec += "_"
        used.add(rec)
        ests, gt = {}, None
        for name in estimators:
            res = run_and_evaluate(ds, name, options=options, progress=progress, max_frames=max_frames)
            rows.append(row_of(rec, name, res))
            for k in range(noise_draws):
                if progress:
                    print(f"{rec}: {name}, noise draw {k + 1} of {noise_draws} (+{noise_sigma:g} grey levels)",
                          file=sys.stderr, flush=True)
                noisy = ImageNoiseDataset(ds, noise_sigma, (k,), REAL_DRAW_TAG)
                draw = run_and_evaluate(noisy, name, options=options, progress=progress, max_frames=max_frames)
                rows[-1].drift_draws_pct.append(float(draw.evaluation.drift.drift_ratio_pct))
            rows[-1].noise_sigma = noise_sigma if noise_draws else 0.0
            ests[name], gt = res.evaluation.aligned_est, res.evaluation.gt_matched
        if out is not None and gt is not None:
            plot = str(plot_recording(rec, gt, ests, out / f"{rec}_trajectory.png"))
            for r in rows[-len(estimators):]:
                r.plot = plot
    return rows


def _noise_sigma(noise_draws, noise_sigma) -> float:
    """``noise_sigma`` as a float, once ``noise_draws`` is checked to be an integer >= 0 and, with draws,
    ``noise_sigma`` a finite number > 0 (else :class:`SimError`, one line naming the argument)."""
    if isinstance(noise_draws, bool) or not isinstance(noise_draws, (int, np.integer)) or noise_draws < 0:
        raise SimError(f"bench real: noise_draws {noise_draws!r}; must be an integer >= 0")
    try:
        sigma = float(noise_sigma)
    except (TypeError, ValueError):
        sigma = float("nan")
    if noise_draws and not (np.isfinite(sigma) and sigma > 0):
        raise SimError(f"bench real: noise_sigma {noise_sigma!r}; must be a finite number > 0 grey levels")
    return sigma


def format_rows(rows) -> str:
    """Plain-text table of :class:`RealBenchRow` (segment errors "-" where the route is under 100 m)."""
    lines = [f"{'recording':<22}{'estimator':<10}{'frames':>7}{'path m':>9}{'drift %':>9}{'est m':>9}{'ATE m':>8}"
             f"{'RPE m':>8}{'RPE deg':>9}{'KITTI %':>9}{'deg/100m':>9}{'ms/frame':>10}{'CPU ms':>8}  frames by status"]
    for r in rows:
        kt = f"{r.kitti_t_err_pct:9.2f}{r.kitti_r_err_deg_per_100m:9.3f}" if r.kitti_segments else f"{'-':>9}{'-':>9}"
        st = " ".join(f"{k} {v}" for k, v in sorted(r.status_counts.items()))
        lines.append(f"{r.recording:<22}{r.estimator:<10}{r.n_frames:7d}{r.path_length_m:9.1f}{r.drift_pct:9.2f}"
                     f"{r.est_length_m:9.1f}{r.ate_rmse_m:8.3f}{r.rpe_trans_rmse_m:8.3f}{r.rpe_rot_rmse_deg:9.3f}{kt}"
                     f"{r.ms_per_frame:10.1f}{r.cpu_ms_per_frame:8.1f}  {st}")
    drawn = [r for r in rows if r.drift_draws_pct]
    if drawn:
        lines += ["", f"drift % under re-drawn image noise (+{drawn[0].noise_sigma:g} grey levels; draw k the same for "
                      f"every estimator)",
                  f"{'recording':<22}{'estimator':<10}{'draws':>6}{'median':>8}{'min':>8}{'max':>8}{'recorded':>10}"]
        for r in drawn:
            d = np.asarray(r.drift_draws_pct)
            lines.append(f"{r.recording:<22}{r.estimator:<10}{len(d):6d}{np.median(d):8.2f}{d.min():8.2f}{d.max():8.2f}"
                         f"{r.drift_pct:10.2f}")
    return "\n".join(lines)
