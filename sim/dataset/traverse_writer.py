"""Write a stop-and-go traverse dataset (seed 001): per-site panoramas, drive streams, truth, a map.

Layout (docs/dataset_layout.md, "Traverse datasets"; read back by :mod:`vo.dataset.traverse_reader`)::

    metadata.yaml                 generator, config, traverse knobs, rig, mast model, site count
    rig.yaml                      the rig (rigs.rig_yaml), cameras at pan 0 / nominal tilt
    sites/groundtruth_tum.txt     true T_w_b per site, time = the site's capture time
    sites/dead_reckoning_tum.txt  dead-reckoning T_w_b per site, same times
    sites/site_NN/site.yaml       index, t_ns, T_w_b_true, T_w_b_dr, cov_dr (6x6), pairs:
                                  [{pair, t_ns, pan/tilt commanded and true (rad), left, right}]
    sites/site_NN/pair_K_{left,right}.png    8-bit grey images
    drive/imu0.csv                EuRoC IMU rows (gyro, accel) over the whole traverse
    drive/wheels.csv              t_ns, left_ticks, right_ticks (six wheels as two sides)
    drive/groundtruth.csv         EuRoC ground-truth rows of the body frame b (p, q_wxyz, v, biases)
    map.png                       hill-shaded terrain (orthoimage-like), route and site numbers
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import yaml

from sim.dataset.common import CsvStream, _plain, write_png
from sim.dataset.euroc_writer import GT_HEADER, IMU_HEADER
from sim.errors import SimError

WHEELS_HEADER = "#timestamp [ns],left_ticks,right_ticks"
DR_RATE_HZ = 20.0


def generate_traverse(config, tcfg, out_dir, progress: bool = True, overwrite: bool = False) -> dict:
    """Plan, simulate and write the traverse of ``config`` (GenerateConfig) with ``tcfg``
    (:class:`sim.traverse.TraverseConfig`) into ``out_dir``; returns a summary dict."""
    from sim.dataset.common import claim_folder
    out = Path(out_dir)
    with claim_folder(out, overwrite):        # locked; --overwrite deletes only a folder of ours
        if (out / "metadata.yaml").exists():
            raise SimError(f"--out {out}: a dataset is already there; pass --overwrite to replace it")
        return _generate_traverse(config, tcfg, out, progress)


def _generate_traverse(config, tcfg, out: Path, progress: bool) -> dict:
    """:func:`generate_traverse` in a claimed folder; ``metadata.yaml`` is written last (atomically), so a
    folder without it is incomplete and a rerun writes it again."""
    from rigs.atomic_io import atomic_write_text
    from sim.traverse import plan
    (out / "sites").mkdir(parents=True, exist_ok=True)
    (out / "drive").mkdir(parents=True, exist_ok=True)
    tp = plan(config, tcfg)
    imu = _write_drive(out, tp, tcfg, config)
    T_dr, C_dr = _dead_reckoning(tp, tcfg, config, imu)
    _write_sites(out, tp, config, T_dr, C_dr, progress)
    _write_tum(out / "sites" / "groundtruth_tum.txt", tp.site_t_ns, tp.T_w_b_sites)
    _write_tum(out / "sites" / "dead_reckoning_tum.txt", tp.site_t_ns, T_dr)
    write_map(out / "map.png", tp, T_dr)
    meta = _metadata(config, tcfg, tp)
    atomic_write_text(out / "metadata.yaml", yaml.safe_dump(_plain(meta), sort_keys=False))
    return {"out_dir": str(out), "n_sites": len(tp.site_t_ns), "n_pairs": len(tp.captures),
            "path_length_m": float(tp.site_s_m[-1]), "duration_s": (tp.trajectory.t1_ns - tp.trajectory.t0_ns) * 1e-9,
            "map_png": str(out / "map.png")}


def _metadata(config, tcfg, tp) -> dict:
    from rigs.rig_yaml import rig_to_dict
    from rigs.typed_config import to_mapping
    from sim.version import __version__
    from sim.vehicles.rover import MastHead
    head = MastHead.from_rig(config.rig)
    return {"generator": "vo-testbed", "kind": "traverse", "version": __version__, "config": config.to_dict(),
            "traverse": to_mapping(tcfg), "seed": config.seed, "rig": rig_to_dict(config.rig),
            "mast": {"T_b_mast": head.T_b_mast, "T_head_c": head.T_head_c, "tilt0_rad": head.tilt0_rad},
            "n_sites": int(len(tp.site_t_ns)), "site_arc_length_m": tp.site_s_m,
            "dead_reckoning": {"filter": "sim.sensors.deadreckoning EKF", "imu_rate_hz": DR_RATE_HZ}}


def _write_drive(out: Path, tp, tcfg, config):
    """IMU (noisy), wheels, body ground truth over the whole traverse; returns the IMU times and gyro."""
    from sim.rng import stream
    from sim.sensors.imu import imu_times_ns, measure
    from sim.sensors.imu_noise import add_imu_noise
    from sim.traverse import wheel_travel
    from rigs.geometry import quat_wxyz_from_R
    traj, rig = tp.trajectory, config.rig
    t_imu = imu_times_ns(traj.t0_ns, traj.t1_ns, rig.imu.rate_hz)
    st = traj.states(t_imu)
    noisy, biases = add_imu_noise(measure(st, rig.imu), rig.imu, stream(config.seed, "imu_white"),
                                  stream(config.seed, "imu_bias"))
    imu = CsvStream(out / "drive" / "imu0.csv", IMU_HEADER, False)
    for t, g, a in zip(noisy.t_ns, noisy.gyro, noisy.accel):
        imu.append(t, [f"{x:.9g}" for x in (*g, *a)])
    imu.close()
    gt = CsvStream(out / "drive" / "groundtruth.csv", GT_HEADER, False)
    for k in range(len(t_imu)):
        q = quat_wxyz_from_R(st.T_w_b[k, :3, :3])
        gt.append(t_imu[k], [f"{x:.9g}" for x in (*st.T_w_b[k, :3, 3], *q, *st.v_w[k], *biases.b_g[k], *biases.b_a[k])])
    gt.close()
    _, slipped, ticks, enc = wheel_travel(tp, tcfg, config.seed)
    wh = CsvStream(out / "drive" / "wheels.csv", WHEELS_HEADER, False)
    for t, l, r in zip(ticks.t_ns, ticks.left_ticks, ticks.right_ticks):
        wh.append(t, [int(l), int(r)])
    wh.close()
    (out / "drive" / "wheels.yaml").write_text(yaml.safe_dump(_plain(dataclasses.asdict(enc)), sort_keys=False))
    tp.wheel_ticks, tp.wheel_encoder = ticks, enc
    return noisy


def _dead_reckoning(tp, tcfg, config, imu):
    """Per-site dead-reckoning pose and covariance: the rover's EKF (:mod:`sim.sensors.deadreckoning`) on the
    written sensors, the IMU block-averaged to :data:`DR_RATE_HZ` (averaging keeps the integrated
    angle and the white-noise density), started from the true initial pose. Its white slip noise is
    the random part of the slip model (``traverse.slip_random_std``); the mean slip is not corrected
    (an on-board filter does not know it) but is in its covariance: a slip-bias state of prior std
    ``traverse.slip`` (at least 0.02); the gyro and accelerometer bias random walks are the rig IMU's."""
    from rigs.records import ImuSamples
    from sim.sensors.deadreckoning import DeadReckoningConfig, dead_reckon
    n = max(1, int(round(config.rig.imu.rate_hz / DR_RATE_HZ)))
    m = (len(imu.t_ns) - 1) // n * n + 1
    blocks = lambda a: np.vstack([a[:1], a[1:m].reshape(-1, n, 3).mean(axis=1)])
    dec = ImuSamples(imu.t_ns[:m:n], blocks(imu.gyro), blocks(imu.accel))
    enc = tp.wheel_encoder
    cfg = DeadReckoningConfig(enc.wheel_radius, enc.ticks_per_rev, gyro_noise_density=config.rig.imu.gyro_noise_density,
                              slip_std=max(tcfg.slip_random_std, 1e-4), slip_bias_std=max(tcfg.slip, 0.02),
                              gyro_bias_walk=config.rig.imu.gyro_random_walk,
                              accel_bias_walk=config.rig.imu.accel_random_walk)
    T_w_b0 = tp.trajectory.states(np.array([tp.trajectory.t0_ns])).T_w_b[0]
    T_i_b = np.linalg.inv(config.rig.imu.T_b_i_array)
    dr = dead_reckon(dec, tp.wheel_ticks, T_i_b[:3, :3].T, T_w_b0, np.diag([1e-8] * 6), cfg)
    return dr.at(np.clip(tp.site_t_ns, dr.t_ns[0], dr.t_ns[-1]))


def _write_sites(out: Path, tp, config, T_dr, C_dr, progress: bool) -> None:
    from tqdm import tqdm
    from sim.rng import indexed_stream
    from sim.render import StereoRenderer
    from sim.sensors.camera import add_noise
    from sim.world import build_world
    from rigs.image import to_gray
    from sim.vehicles.rover import MastHead
    head = MastHead.from_rig(config.rig)
    sigma = 0.0 if config.ideal else config.noise.image_sigma
    by_site = {}
    for c in tp.captures:
        by_site.setdefault(c.site, []).append(c)
    world = build_world(tp.scene, config.rig, vehicle="rover")
    # the rover itself is not drawn: at a low sun its shadow on a 1024-texel map over 80 m is blocky
    with StereoRenderer(world, config.rig, supersample=config.render.supersample, show_vehicle=False) as cam:
        bar = tqdm(total=len(tp.captures), desc="panoramas", unit="pair", disable=not progress, dynamic_ncols=True)
        for k, caps in sorted(by_site.items()):
            folder = out / "sites" / f"site_{k:02d}"
            folder.mkdir(parents=True, exist_ok=True)
            pairs = []
            for c in caps:
                head.set_pointing(world, c.pan_true, c.tilt_true)
                images = [to_gray(img) for img in cam.render(tp.T_w_b_sites[k]).images[:2]]
                index = k * 100 + c.pair
                images = add_noise(images, sigma, indexed_stream(config.seed, "image_noise", index))
                names = [f"pair_{c.pair}_{side}.png" for side in ("left", "right")]
                for name, img in zip(names, images):
                    write_png(folder / name, img, rgb=False)
                pairs.append({"pair": c.pair, "t_ns": c.t_ns, "pan_cmd_rad": c.pan_cmd, "tilt_cmd_rad": c.tilt_cmd,
                              "pan_true_rad": c.pan_true, "tilt_true_rad": c.tilt_true,
                              "left": names[0], "right": names[1]})
                bar.update(1)
            site = {"index": k, "t_ns": int(tp.site_t_ns[k]), "arc_length_m": float(tp.site_s_m[k]),
                    "T_w_b_true": tp.T_w_b_sites[k], "T_w_b_dr": T_dr[k], "cov_dr": C_dr[k], "pairs": pairs}
            (folder / "site.yaml").write_text(yaml.safe_dump(_plain(site), sort_keys=False))
        bar.close()


def _write_tum(path: Path, t_ns, T) -> None:
    from rigs.trajectory import Trajectory
    from rigs.trajfile import write_tum
    write_tum(path, Trajectory(np.asarray(t_ns, np.int64), np.asarray(T), ref="w", frame="b"))


def write_map(path: Path, tp, T_dr=None, extra: dict = None) -> None:
    """Top-down hill-shaded terrain (sun of the scene) with the true route, site numbers and, if
    given, the dead-reckoning sites and ``extra`` {label: (S,2) xy} tracks."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rigs.figures import save_figure
    sc = tp.scene
    xmin, xmax, ymin, ymax = sc.extent_xy()
    gy, gx = np.gradient(sc.z, getattr(sc, "res_m", 0.25))
    n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    shade = np.clip((n @ sc.sun_direction()) / np.linalg.norm(n, axis=-1), 0, 1)
    xy = tp.trajectory.states(np.linspace(tp.trajectory.t0_ns, tp.trajectory.t1_ns, 2000).astype(np.int64)).T_w_b[:, :2, 3]
    sites = tp.T_w_b_sites[:, :2, 3]
    pad = 12.0
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.imshow(shade, cmap="gray", origin="lower", extent=(xmin, xmax, ymin, ymax))
    ax.plot(xy[:, 0], xy[:, 1], "b-", lw=1, label="true traverse")
    ax.plot(sites[:, 0], sites[:, 1], "go", ms=4, label="sites (truth)")
    if T_dr is not None:
        ax.plot(T_dr[:, 0, 3], T_dr[:, 1, 3], "r^--", ms=3, lw=0.8, label="dead reckoning")
    for label, pts in (extra or {}).items():
        ax.plot(pts[:, 0], pts[:, 1], "s-", ms=3, lw=0.8, label=label)
    for k, (x, y) in enumerate(sites):
        ax.annotate(str(k), (x, y), xytext=(4, 4), textcoords="offset points", color="yellow", fontsize=8)
    ax.set_xlim(sites[:, 0].min() - pad, sites[:, 0].max() + pad)
    ax.set_ylim(sites[:, 1].min() - pad, sites[:, 1].max() + pad)
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.legend(loc="best", fontsize=8)
    save_figure(fig, str(path))
