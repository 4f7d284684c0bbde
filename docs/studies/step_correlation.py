"""Keyframe steps of ``rop`` over re-rendered scenes: is each step's bootstrap covariance right, and are
consecutive steps independent? (docs/studies/rop_consistency.md, "Bootstraps over tracks").

Usage: .venv/bin/python docs/studies/step_correlation.py [--runs 30] [--workers 2] [KEY=VALUE ...]
Run k: campus-short rendered at 3x (``render.supersample=3``, cached) from scenario seed 1 + k, image
noise seed 1000 + k, as ``vo-testbed consistency --vary scene``; ``rop`` with the independent-steps
track bootstrap (:class:`rop_models.RecordingBootstrap`, which keeps each step's covariance) and the RopConfig options given.
Per keyframe-to-keyframe step ``j``: the error of the estimated ``T_kf_kf'``
against the truth (left perturbation in the keyframe frame) and the step's bootstrap covariance.
Prints the per-axis std of the step errors over their bootstrap std (demeaned per step index), the
correlation of step ``j`` with step ``j + lag`` per axis, and the std over runs of the summed step
errors against the square root of the summed bootstrap variances (what chaining independent
steps predicts).
"""
import argparse
import multiprocessing
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np
import yaml

np.set_printoptions(precision=2, suppress=True, linewidth=200)
AXES = "rx ry rz x y z"


def one_run(k: int, options: dict):
    """-> (steps, 6) errors and (steps, 6, 6) bootstrap covariances of run k's keyframe steps."""
    import cv2
    cv2.setNumThreads(1)
    from sim.app.nees import NoisyDataset
    from sim.scenarios import cached_dataset, get_scenario
    from vo.dataset import open_dataset
    from rigs.geometry import pose_error_left
    from vo.estimators.runner import run_estimator
    cfg = replace(get_scenario("campus-short", overrides=("render.supersample=3",)), ideal=True)
    base = open_dataset(cached_dataset(replace(cfg, seed=cfg.seed + 1 + k), progress=False))
    gt = base.groundtruth_cam0().T
    T, kf, cov = [], [0], []

    def on_frame(frame, r, est):
        T.append(r.T_o_c0)
        if r.status == "keyframe":
            kf.append(frame.index)
            cov.append(est.uncertainty.step_covs[int(frame.t_ns)])

    run_estimator("rop_models:RecordingBootstrap", NoisyDataset(base, 1.0, 1000 + k, imu_model=None), options,
                  progress=False, on_frame=on_frame)
    err = [pose_error_left(np.linalg.inv(T[a]) @ T[b], np.linalg.inv(gt[a]) @ gt[b]) for a, b in zip(kf, kf[1:])]
    return np.array(err), np.array(cov)


def main(argv):
    ap = argparse.ArgumentParser(description="rop keyframe steps: bootstrap std and step correlation")
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("options", nargs="*", help="RopConfig options KEY=VALUE (values parsed as YAML)")
    args = ap.parse_args(argv)
    runs, workers = args.runs, args.workers
    options = {k: yaml.safe_load(v) for k, v in (a.split("=", 1) for a in args.options)}
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        out = list(pool.map(one_run, range(runs), [options] * runs))
    n = min(len(e) for e, _ in out)
    E = np.array([e[:n] for e, _ in out])                       # (runs, steps, 6)
    V = np.array([[np.diag(c) for c in C[:n]] for _, C in out])
    D = E - E.mean(axis=0)                                       # demeaned per step index
    print(f"{runs} runs, {n} keyframe steps each; axes {AXES} (rad, m)")
    print("step error std / bootstrap std:", np.sqrt((D ** 2).sum((0, 1)) / (runs - 1) / n / V.mean((0, 1))))
    for lag in (1, 2, 3):
        c = [np.corrcoef(D[:, :-lag, a].ravel(), D[:, lag:, a].ravel())[0, 1] for a in range(6)]
        print(f"correlation of steps j, j+{lag}:", np.array(c))
    s = D.sum(axis=1)
    print("summed steps: std over runs", s.std(0, ddof=1) * 1e3, "(mrad, mm)")
    print("  independent-steps prediction", np.sqrt(V.sum(1).mean(0)) * 1e3,
          "ratio", s.std(0, ddof=1) / np.sqrt(V.sum(1).mean(0)))


if __name__ == "__main__":
    main(sys.argv[1:])
