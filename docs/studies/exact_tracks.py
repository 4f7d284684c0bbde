"""Front-end vs back-end: ``rop`` on exact track positions (sim.app.validation.truth_tracks), docs/studies/rop_consistency.md.

Usage: .venv/bin/python docs/studies/exact_tracks.py [--scenes N] [--exact p2,p3,p4] [--noise PX]
                                                      [--record OUT.pkl] [KEY=VALUE ...]
Scene k is campus-short rendered (ideal, with depth, cached) from scenario seed 1 + k, k = 0..N-1 (default 6);
prints each scene's end-point error and the run mean (the same figures as scene_bias.py).
``--exact`` chooses the positions replaced (default all three, ``none`` for plain KLT; the others stay KLT's on the images
re-noised with seed 1000 + k, as in scene_bias.py); ``--noise`` adds iid pixel noise to the exact ones;
``--record`` pickles KLT vs exact positions of every keyframe / tracked frame (all scenes, in order).
For the Monte-Carlo NEES of the exact-track front-end use ``vo-testbed consistency --oracle-tracks PX``.
"""
import pickle
import sys
from dataclasses import replace

import numpy as np

from sim.app.nees import NoisyDataset, pose_errors
from sim.scenarios import cached_dataset, get_scenario
from sim.app.validation.truth_tracks import VIEWS, run_oracle
from vo.dataset import open_dataset

np.set_printoptions(precision=3, suppress=True, linewidth=200)


def _pop(argv, flag, default, cast=str):
    if flag not in argv:
        return default
    i = argv.index(flag)
    value = cast(argv[i + 1])
    del argv[i:i + 2]
    return value


def main(argv):
    n_scenes = _pop(argv, "--scenes", 6, int)
    exact = _pop(argv, "--exact", ",".join(VIEWS))
    exact = () if exact == "none" else tuple(exact.split(","))
    noise = _pop(argv, "--noise", 0.0, float)
    record_path = _pop(argv, "--record", None)
    record = [] if record_path else None
    opts = dict(a.split("=", 1) for a in argv)
    cfg = replace(get_scenario("campus-short"), ideal=True, depth=True)
    R, P = [], []
    for s in range(n_scenes):
        ds = open_dataset(cached_dataset(replace(cfg, seed=cfg.seed + 1 + s), progress=False))
        gt = ds.groundtruth_cam0()
        images = ds if set(exact) == set(VIEWS) and record is None else NoisyDataset(ds, 1.0, 1000 + s)
        frames = run_oracle(ds, opts, noise, 1000 + s, exact, record=record, images=images)
        T = np.array([f.T_o_c0 for f in frames])
        er, ep = pose_errors((np.linalg.inv(gt.T[0]) @ gt.T)[:len(T)], T)
        R.append(er[-1]); P.append(ep[-1])
        print(s, "rot(mrad)", er[-1] * 1e3, "pos(mm)", ep[-1] * 1e3, flush=True)
    if record_path:
        with open(record_path, "wb") as fh:
            pickle.dump(record, fh)
    n = np.sqrt(len(R))
    print("mean rot (mrad)", np.mean(R, 0) * 1e3, "+-", np.std(R, 0) * 1e3 / n)
    print("mean pos (mm)  ", np.mean(P, 0) * 1e3, "+-", np.std(P, 0) * 1e3 / n)


if __name__ == "__main__":
    main(sys.argv[1:])
