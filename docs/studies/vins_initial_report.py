"""How well ``vins`` starts on one dataset: ``python docs/studies/vins_initial_report.py DATASET [FRAMES] [key=value ...]``.

Runs ``vins`` (estimator options ``key=value``) until its first non-``init`` frame (at most FRAMES, default 300)
and compares the start with the dataset's truth: the alignment's scale and gravity errors
(:class:`vins_start_table.InitRecorder`, injected as the estimator's initializer), and after the first window
optimisation the keyframes' scale (path lengths from the first state) and tilt of the newest camera (yaw is
unobservable). Bad input: one ``error:`` line, exit 2.
"""
from __future__ import annotations

import sys

import numpy as np

from rigs.errors import TestbedError
from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.estimators.runner import run_estimator
from vins_start_table import InitRecorder


def report(dataset_path, n_frames: int = 300, **options) -> str:
    """One line: the start of ``vins`` on the dataset at ``dataset_path`` against its truth (module docstring)."""
    ds = open_dataset(dataset_path)
    gt = ds.groundtruth_cam0()
    k_of = {int(t): k for k, t in enumerate(gt.t_ns)}
    rec = InitRecorder(gt)
    run = run_estimator("vins", ds, {**options, "initializer": rec}, progress=False, max_frames=n_frames,
                        with_truth=True, on_frame=lambda frame, res, est: res.status != "init")
    if run.frames[-1].status == "init":
        return f"{dataset_path}: no initialisation in {n_frames} frames"
    k = len(run.frames) - 1
    seen = rec.starts[0]
    w = run.estimator.window
    T_e = np.array([w.T_w_c(st) for st in w.states])
    T_g = gt.T[[k_of[st.t_ns] for st in w.states]]
    d_e, d_g = (np.linalg.norm(T[:, :3, 3] - T[0, :3, 3], axis=1) for T in (T_e, T_g))
    up_e, up_g = T_e[-1, :3, :3].T[:, 2], T_g[-1, :3, :3].T[:, 2]
    tilt = np.degrees(np.arccos(np.clip(up_e @ up_g, -1, 1)))
    return (f"{dataset_path}: init at frame {k} (keyframes {seen['keyframes'][0]}..{seen['keyframes'][1]}); "
            f"alignment scale error {seen['scale_err_pct']:+.2f} %, gravity error {seen['gravity_err_deg']:.3f} "
            f"deg; after the first window optimisation scale error "
            f"{(np.sum(d_e * d_g) / np.sum(d_g ** 2) - 1) * 100:+.2f} %, tilt {tilt:.3f} deg")


def main(argv=None) -> int:
    """CLI (module docstring): one-line error and exit 2 on bad arguments or a bad dataset."""
    args = list(sys.argv[1:] if argv is None else argv)
    n_arg = len(args) > 1 and args[1].isdigit()
    opts = args[1 + n_arg:]
    if not args or not all("=" in a for a in opts):
        print("usage: python docs/studies/vins_initial_report.py DATASET [FRAMES (default 300)] "
              "[vins option key=value ...]", file=sys.stderr)
        return 2
    try:
        print(report(args[0], int(args[1]) if n_arg else 300,
                     **{k: parse_value(v, k, EstimatorError) for k, v in (a.split("=", 1) for a in opts)}))
    except TestbedError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
