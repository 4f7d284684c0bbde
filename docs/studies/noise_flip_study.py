"""What sets rop's run-to-run spread when only the image noise changes (docs/studies/rop_consistency.md, "The bistable inlier gate").

Two measurements on campus-short (3x rendering, 11 px LK window), runs k = 0..N-1 re-noised with
seed 1000 + k (sim.app.nees.NoisyDataset, as `vo-testbed consistency`):

  sweep  - end-point position std over N runs for each image-noise sigma and rop_loss:
           python docs/studies/noise_flip_study.py sweep --sigmas 0.25,1 --losses gate,tukey --runs 16
  steps  - per keyframe step, the spread of the step's forward translation over N runs, each step
           re-solved from the run's own tracks with every rop_loss, and with only the tracks common to
           the run and run 0 (matched within 0.5 px at the keyframe):
           python docs/studies/noise_flip_study.py steps --sigma 0.25 --runs 8
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
SCENARIO, OVERRIDES, WIN = "campus-short", ("render.supersample=3",), 11


def _base():
    from sim.scenarios import cached_dataset, get_scenario
    from vo.dataset import open_dataset
    cfg = replace(get_scenario(SCENARIO, overrides=OVERRIDES), ideal=True)
    return open_dataset(cached_dataset(cfg, progress=False))


def _end_error(args) -> np.ndarray:
    """End-point position error (mm) of one run."""
    k, sigma, loss = args
    from sim.app.nees import NoisyDataset, pose_errors
    from vo.estimators.runner import run_estimator
    base = _base()
    T = run_estimator("rop", NoisyDataset(base, sigma, 1000 + k), {"klt_config": {"win": WIN}, "experimental.rop_loss": loss},
                      progress=False).trajectory.T
    gt = base.groundtruth_cam0()
    T_true = np.linalg.inv(gt.T[0]) @ gt.T
    return pose_errors(T_true[:len(T)], T)[1][-1] * 1e3


def _step_inputs(args) -> list:
    """Per keyframe step of one run: the pairs, R_1_3 and ROP priors that rop solved it from."""
    k, sigma = args
    from sim.app.nees import NoisyDataset
    from vo.estimators.runner import run_estimator
    seen, out = {}, []

    def keep(frame, res, est):
        if res.status == "keyframe" and "in" in seen:
            out.append(seen["in"])
        seen.clear()
    run_estimator("rop", NoisyDataset(_base(), sigma, 1000 + k),
                  {"klt_config": {"win": WIN}, "step_observer": lambda *inputs: seen.update({"in": inputs})},
                  progress=False, on_frame=keep)
    return out


def _resolve(rig, inputs, loss, rows=None) -> float:
    """Forward translation (mm) of a step re-solved from its inputs (optionally a subset of rows per pair)."""
    from vo.rop.estimator import RopEstimator
    pairs, R_1_3, priors = inputs
    if rows is not None:
        pairs = {p: (a[rows[p]], b[rows[p]]) for p, (a, b) in pairs.items()}
    T = RopEstimator(rig, klt_config={"win": WIN}, experimental={"rop_loss": loss}).solve_step(pairs, R_1_3, priors)
    return float(T[2, 3]) * 1e3 if T is not None else float("nan")


def _common_rows(a, b, tol=0.5 / 504):
    """Rows of each pair present in both runs (keyframe point within ``tol``, normalised units)."""
    from scipy.spatial import cKDTree
    ra, rb = {}, {}
    for p in a[0]:
        d, j = cKDTree(b[0][p][0]).query(a[0][p][0])
        ia = np.flatnonzero(d < tol)
        ia = ia[np.unique(j[ia], return_index=True)[1]]
        ra[p], rb[p] = ia, j[ia]
    return ra, rb


def _pool(fn, args):
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(fn, args))


def sweep(sigmas, losses, runs):
    for loss in losses:
        for s in sigmas:
            e = np.array(_pool(_end_error, [(k, s, loss) for k in range(runs)]))
            std = e.std(axis=0, ddof=1)
            print(f"rop_loss {loss:6s} sigma {s:5.2f}: {runs} runs, end std x/y/z {np.round(std, 2)} mm, "
                  f"3-D {np.sqrt((std ** 2).sum()):.2f} mm, mean {np.round(e.mean(axis=0), 2)} mm")


def steps(sigma, runs, losses):
    data = _pool(_step_inputs, [(k, sigma) for k in range(runs)])
    rig = _base().rig
    n = min(len(d) for d in data)
    for loss in losses:
        full = np.array([[_resolve(rig, d[s], loss) for s in range(n)] for d in data])
        diff_common = []
        for s in range(n):
            dc = []
            for d in data[1:]:
                ra, rb = _common_rows(data[0][s], d[s])
                dc.append(_resolve(rig, d[s], loss, rb) - _resolve(rig, data[0][s], loss, ra))
            diff_common.append(np.std(dc, ddof=1) / np.sqrt(2.0))
        print(f"rop_loss {loss}: per-step forward std (mm) {np.round(full.std(axis=0, ddof=1), 2)}")
        print(f"  common tracks only (std of run k - run 0, / sqrt 2): {np.round(diff_common, 2)}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=("sweep", "steps"))
    ap.add_argument("--sigmas", default="0.25,0.5,1,2")
    ap.add_argument("--sigma", type=float, default=0.25)
    ap.add_argument("--losses", default="gate,tukey")
    ap.add_argument("--runs", type=int, default=16)
    a = ap.parse_args()
    losses = a.losses.split(",")
    if a.what == "sweep":
        sweep([float(s) for s in a.sigmas.split(",")], losses, a.runs)
    else:
        steps(a.sigma, a.runs, losses)


if __name__ == "__main__":
    main()
