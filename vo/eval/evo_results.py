"""An evaluation as evo's result file (``evo_ape --save_results``), which ``evo_res`` reads.

Written with evo's own :func:`evo.tools.file_interface.save_res_file` (evo is the ``evo`` extra; it is
imported only here): a zip holding ``info.json`` (title, ``ref_name``, ``est_name``, label),
``stats.json`` (rmse, mean, median, std, min, max, sse of the APE translation error in metres, as
``evo_ape`` with its default ``translation_part``), ``error_array.npy``, ``timestamps.npy`` (s),
``seconds_from_start.npy``, ``distances_from_start.npy`` / ``distances.npy`` (m along the ground
truth / the estimate) and the two matched trajectories (ground truth, aligned estimate) as TUM text.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rigs.atomic_io import atomic_write
from vo.errors import VoError


def _evo():
    try:
        from evo.core.result import Result
        from evo.core.trajectory import PoseTrajectory3D
        from evo.tools.file_interface import save_res_file
    except ImportError:
        raise VoError("--save-results: writing evo's result format needs evo (pip install 'vo-testbed[evo]')") from None
    return Result, PoseTrajectory3D, save_res_file


def evo_result(result, ref_name: str, est_name: str):
    """:class:`vo.eval.EvalResult` -> ``evo.core.result.Result`` of its APE translation error."""
    Result, PoseTrajectory3D, _ = _evo()
    e = np.asarray(result.ape.t_err_m, dtype=float)
    gt, est = result.gt_matched, result.aligned_est
    res = Result()
    res.add_info({"title": f"APE w.r.t. translation part (m)\n(alignment: {result.alignment.method})",
                  "ref_name": ref_name, "est_name": est_name, "label": "APE (m)"})
    res.add_stats({"rmse": float(np.sqrt(np.mean(e ** 2))), "mean": float(np.mean(e)), "median": float(np.median(e)),
                   "std": float(np.std(e)), "min": float(np.min(e)), "max": float(np.max(e)),
                   "sse": float(np.sum(e ** 2))})
    res.add_np_array("error_array", e)
    t_s = est.t_ns.astype(np.float64) * 1e-9
    res.add_np_array("timestamps", t_s)
    res.add_np_array("seconds_from_start", (est.t_ns - est.t_ns[0]).astype(np.float64) * 1e-9)
    for name, traj in (("distances_from_start", gt), ("distances", est)):
        steps = np.linalg.norm(np.diff(traj.positions, axis=0), axis=1)
        res.add_np_array(name, np.concatenate([[0.0], np.cumsum(steps)]))
    res.add_trajectory(ref_name, PoseTrajectory3D(poses_se3=list(gt.T), timestamps=gt.t_ns * 1e-9))
    res.add_trajectory(est_name, PoseTrajectory3D(poses_se3=list(est.T), timestamps=t_s))
    return res


def save_evo_result(result, path, ref_name: str, est_name: str) -> Path:
    """Write ``path`` (a .zip) atomically with evo's ``save_res_file``; returns the path."""
    res = evo_result(result, ref_name, est_name)
    _, _, save_res_file = _evo()
    return atomic_write(path, lambda tmp: save_res_file(tmp, res))
