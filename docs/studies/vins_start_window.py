"""Where the start's scale error comes from, on the first window whose SfM succeeds.

``python docs/studies/vins_start_window.py DATASET [FRAMES] [key=value ...]`` runs ``vins`` (options as
``--opt``) until the first start attempt whose SfM succeeds (default: the first 120 frames) and prints, for that
window of keyframes: the alignment's scale error against the truth (``vo.vins.vi_init.align`` on the SfM as it
is), the same alignment with the SfM camera centres replaced by the true ones (rotations kept), the SfM centres'
errors after a least-squares scale (cm), the share of the tracks' observations farther than 3 px from the
reprojection of a point triangulated from the true poses, and the SfM bundle adjustment started from the true
poses (does it stay there?). Bad input: one ``error:`` line, exit 2.
"""
from __future__ import annotations

import sys

import numpy as np

from rigs.errors import TestbedError
from rigs.typed_config import parse_value
from vo.dataset import open_dataset
from vo.errors import EstimatorError
from vo.estimators.runner import run_estimator
from vo.vins import sfm as sfm_mod
from vo.vins.estimator import VinsEstimator
from vo.vins.vi_init import align, gyro_bias, initialize


class _FirstWindow(Exception):
    pass


def first_window(path, n_frames: int, options: dict):
    """-> (dataset, keyframes) of the first start attempt whose SfM succeeds, or None."""
    ds = open_dataset(path)
    got = {}

    def init(stream, params, frames, T_i_c, config):
        if sfm_mod.sfm(frames, config.init_min_parallax_px, config.virtual_focal) is not None:
            got["frames"] = list(frames)
            return None, "window found"
        return initialize(stream, params, frames, T_i_c, config)

    def on_frame(fr, res, est):
        if "frames" in got:
            raise _FirstWindow
    try:
        run_estimator("vins", ds, {**options, "initializer": init}, progress=False, max_frames=n_frames,
                      with_truth=True, on_frame=on_frame)
    except _FirstWindow:
        pass
    return (ds, got["frames"]) if "frames" in got else None


def scale_error(est, frames, R_v_c, p_v_c, p_true) -> float:
    """Alignment's scale against the least-squares scale of ``p_v_c`` onto ``p_true``, minus 1 (%)."""
    s_true = np.sum(p_v_c * p_true) / np.sum(p_v_c ** 2)
    bg = gyro_bias(est.stream, est.params, frames, R_v_c @ np.linalg.inv(est.T_i_c)[:3, :3])
    s = align(est.stream, est.params, frames, R_v_c, p_v_c, est.T_i_c, bg)[2]
    return 100.0 * (s / s_true - 1.0)


def report(path, n_frames: int, options: dict) -> None:
    got = first_window(path, n_frames, options)
    if got is None:
        print(f"{path}: no SfM succeeded in {n_frames} frames")
        return
    ds, frames = got
    gt = ds.groundtruth_cam0()
    est = VinsEstimator(ds.rig, **options)
    est.set_imu(ds.imu)
    cfg = est.config
    k_of = {int(t): k for k, t in enumerate(gt.t_ns)}
    ks = [k_of[int(f.t_ns)] for f in frames]
    ref, (T_c_v, _) = sfm_mod.sfm(frames, cfg.init_min_parallax_px, cfg.virtual_focal)
    T_v_c = np.linalg.inv(T_c_v)
    T_true = np.linalg.inv(gt.T[ks[ref]]) @ gt.T[ks]
    p, q = T_v_c[:, :3, 3], T_true[:, :3, 3]
    s = np.sum(p * q) / np.sum(p ** 2)
    print(f"{path}: keyframes {ks} (reference {ks[ref]}), klt_refine {cfg.klt_refine}")
    print(f"  alignment scale error {scale_error(est, frames, T_v_c[:, :3, :3], p, q):+.2f} % (SfM as is), "
          f"{scale_error(est, frames, T_v_c[:, :3, :3], q / s, q):+.2f} % (true centres, SfM rotations)")
    print(f"  SfM centre errors cm {np.round(100 * np.linalg.norm(s * p - q, axis=1), 1).tolist()}")
    T_t = np.linalg.inv(T_true)
    points = {}
    for a in range(len(frames) - 1):
        for c in range(len(frames) - 1, a, -1):
            sfm_mod._add_points(points, frames, T_t, a, c)
    err = [np.linalg.norm((lambda pc: pc[:2] / pc[2])(T_t[k][:3, :3] @ points[int(i)] + T_t[k][:3, 3]) - xy)
           * cfg.virtual_focal for k, f in enumerate(frames) for i, xy in zip(f.ids, f.xy) if int(i) in points]
    err = np.array(err)
    print(f"  observations at the true poses: median {np.median(err):.2f} px, beyond 3 px {100 * np.mean(err > 3):.1f} % "
          f"of {len(err)}")
    T1, P1 = sfm_mod._bundle_adjust(frames, T_t, points, ref, cfg.virtual_focal, second=len(frames) - 1)
    T2, _ = sfm_mod._bundle_adjust(frames, T1, P1, ref, cfg.virtual_focal, sfm_mod.REJECT_PX, second=len(frames) - 1)
    p2 = np.linalg.inv(T2)[:, :3, 3]
    print(f"  SfM bundle adjustment from the true poses: alignment scale error "
          f"{scale_error(est, frames, np.linalg.inv(T2)[:, :3, :3], p2, q):+.2f} %")


def main(argv=None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0].startswith("-"):
        print("usage: python docs/studies/vins_start_window.py DATASET [FRAMES] [key=value ...]", file=sys.stderr)
        return 2
    path, n = args.pop(0), 120
    try:
        if args and "=" not in args[0]:
            n = int(args.pop(0))
        opts = {}
        for a in args:
            k, v = a.split("=", 1)
            opts[k] = parse_value(v, k, EstimatorError)
        report(path, n, opts)
    except (ValueError, TestbedError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
