"""Run-mean end-point error of an estimator over re-rendered campus-short scenes (docs/studies/rop_consistency.md).

Usage: .venv/bin/python docs/studies/scene_bias.py ESTIMATOR [KEY=VALUE ...] [--rig NAME] [--set KEY=VALUE ...]
                                                    [--scenes N]
e.g. ``klt-pnp``, ``rop frontend=sift``, ``rop --set cameras.dist=[0,0,0,0,0]``, ``rop --rig stereo27``.
Scene k is campus-short rendered (ideal, cached) from scenario seed 1 + k, k = 0..N-1 (default 6),
re-noised with seed 1000 + k. Estimator option values are passed as strings, except ``klt.<field>=V`` (a
:class:`vo.frontend.klt.KltConfig` field, e.g. ``klt.lk_eps=0.001``); ``--set`` values are
scenario overrides (rig, ``scene.*``, ``motion.*``)."""
import numpy as np, sys
from dataclasses import replace
from sim.scenarios import cached_dataset, get_scenario
from sim.app.nees import NoisyDataset, pose_errors
from vo.dataset import open_dataset
from vo.estimators.runner import run_estimator
np.set_printoptions(precision=3, suppress=True, linewidth=200)
args, sets, rig, n_scenes = sys.argv[1:], [], None, 6
while "--set" in args:
    i = args.index("--set"); sets.append(args[i + 1]); del args[i:i + 2]
if "--rig" in args:
    i = args.index("--rig"); rig = args[i + 1]; del args[i:i + 2]
if "--scenes" in args:
    i = args.index("--scenes"); n_scenes = int(args[i + 1]); del args[i:i + 2]
ideal = replace(get_scenario("campus-short", overrides=sets), ideal=True)
if rig:
    ideal = replace(ideal, rig=rig)
name = args[0]; opts = dict(a.split("=", 1) for a in args[1:])
klt = {k[4:]: float(v) if "." in v or "e" in v else int(v) for k, v in opts.items() if k.startswith("klt.")}
opts = {k: v for k, v in opts.items() if not k.startswith("klt.")}
if klt:
    from vo.frontend.klt import KltConfig
    opts["klt_config"] = KltConfig(**klt)
R, P = [], []
for k in range(n_scenes):
    base = open_dataset(cached_dataset(replace(ideal, seed=ideal.seed + 1 + k), progress=False))
    gt = base.groundtruth_cam0(); Tt = np.linalg.inv(gt.T[0]) @ gt.T
    run = run_estimator(name, NoisyDataset(base, 1.0, 1000 + k), options=opts, progress=False)
    T = np.array([f.T_o_c0 for f in run.frames]); er, ep = pose_errors(Tt[:len(T)], T)
    R.append(er[-1]); P.append(ep[-1])
    print(k, "rot(mrad)", er[-1] * 1e3, "pos(mm)", ep[-1] * 1e3, flush=True)
n = np.sqrt(len(R))
print("mean rot (mrad)", np.mean(R, 0) * 1e3, "+-", np.std(R, 0) * 1e3 / n)
print("mean pos (mm)  ", np.mean(P, 0) * 1e3, "+-", np.std(P, 0) * 1e3 / n)
