"""Run-mean end-point error of an estimator over re-rendered campus-short scenes (docs/consistency.md).

Usage: .venv/bin/python docs/scripts/scene_bias.py ESTIMATOR [KEY=VALUE ...]   e.g.  klt-pnp   or   rop frontend=sift
Scene k is campus-short rendered (ideal, cached) from scenario seed 1 + k, k = 0..5, re-noised with seed 1000 + k.
Option values are passed as strings."""
import numpy as np, sys
from dataclasses import replace
from sim.scenarios import cached_dataset, get_scenario
from sim.montecarlo import NoisyDataset, pose_errors
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
np.set_printoptions(precision=3, suppress=True, linewidth=200)
ideal = replace(get_scenario("campus-short"), ideal=True)
name = sys.argv[1]; opts = dict(a.split("=") for a in sys.argv[2:])
R, P = [], []
for k in range(6):
    base = open_dataset(cached_dataset(replace(ideal, seed=ideal.seed + 1 + k), progress=False))
    gt = base.groundtruth_cam0(); Tt = np.linalg.inv(gt.T[0]) @ gt.T
    run = run_estimator(name, NoisyDataset(base, 1.0, 1000 + k), options=opts, progress=False)
    T = np.array([f.T_o_c0 for f in run.frames]); er, ep = pose_errors(Tt[:len(T)], T)
    R.append(er[-1]); P.append(ep[-1])
    print(k, "rot(mrad)", er[-1] * 1e3, "pos(mm)", ep[-1] * 1e3, flush=True)
print("mean rot", np.mean(R, 0) * 1e3, "std", np.std(R, 0) * 1e3)
print("mean pos", np.mean(P, 0) * 1e3, "std", np.std(P, 0) * 1e3)
