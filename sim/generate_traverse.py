"""Generate a stop-and-go traverse dataset (seed 001): plan, simulate, render; the writer only writes.

``generate_traverse(config, tcfg, out_dir)`` is what ``vo-testbed generate --scenario yutu-traverse`` calls;
the files are written by :mod:`sim.writers.traverse_writer`. It follows :func:`sim.generate.generate`'s stages:
the output folder is claimed and locked (:func:`sim.writers.common.claim_folder`); the IMU is measured and
made noisy as there (:func:`sim.generate.measured_imu`); the panorama pairs go through the same frame loop
(:class:`sim.frame_pipeline.FrameLoop`: rendering on this thread, grey conversion, image noise, PNG encoding and
writing on workers, a site's ``site.yaml`` committed in order once its pairs exist); ``metadata.yaml`` is
written last, atomically, so a folder without it is incomplete and a rerun writes it again. On top of
those, the rover's onboard dead reckoning (:mod:`sim.sensors.deadreckoning`) runs on the written sensors.
Random streams: ``motion``, ``mast`` (:mod:`sim.traverse_plan`), ``imu_white``, ``imu_bias``, ``wheels``, and
``image_noise`` indexed ``100 site + pair``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rigs.image import to_gray
from rigs.records import ImuSamples
from rigs.rig_yaml import rig_to_dict
from rigs.typed_config import to_mapping
from sim.writers.common import claim_folder
from sim.writers.traverse_writer import TraverseWriter
from sim.errors import SimError
from sim.frame_pipeline import FrameLoop
from sim.generate import measured_imu
from sim.rng import indexed_stream
from sim.sensors.camera import add_noise
from sim.sensors.deadreckoning import DeadReckoningConfig, dead_reckon
from sim.sensors.imu import imu_times_ns
from sim.traverse_plan import plan, wheel_travel
from sim.vehicles.rover import MastHead
from sim.version import __version__

DR_RATE_HZ = 20.0             # the dead-reckoning filter's IMU rate (block averages of the written IMU)


def generate_traverse(config, tcfg, out_dir, progress: bool = True, overwrite: bool = False,
                      threads: int | None = None) -> dict:
    """Plan, simulate and write the traverse of ``config`` (GenerateConfig) with ``tcfg``
    (:class:`sim.traverse_plan.TraverseConfig`) into ``out_dir``; returns a summary dict. ``threads``: the frame
    loop's workers (:class:`sim.frame_pipeline.FramePipeline`; the bytes do not depend on it)."""
    out = Path(out_dir)
    with claim_folder(out, overwrite):        # locked; --overwrite deletes only a folder of ours
        if (out / "metadata.yaml").exists():
            raise SimError(f"--out {out}: a dataset is already there; pass --overwrite to replace it")
        return _generate_traverse(config, tcfg, out, progress, threads)


def _generate_traverse(config, tcfg, out: Path, progress: bool, threads: int | None) -> dict:
    """:func:`generate_traverse` in a claimed folder."""
    writer = TraverseWriter(out)
    tp = plan(config, tcfg)
    traj, rig = tp.trajectory, config.rig
    t_imu = imu_times_ns(traj.t0_ns, traj.t1_ns, rig.imu.rate_hz)
    st = traj.states(t_imu)
    imu, biases = measured_imu(st, rig.imu, config.seed, config.ideal)
    _, _, ticks, enc = wheel_travel(tp, tcfg, config.seed)
    writer.write_drive(imu, st, biases, ticks, enc)
    T_dr, C_dr = dead_reckoning(tp, tcfg, config, imu, ticks, enc)
    render_sites(tp, config, writer, T_dr, C_dr, progress, threads)
    writer.write_site_tracks(tp.site_t_ns, tp.T_w_b_sites, T_dr)
    writer.write_map(tp, T_dr)
    writer.finish(metadata(config, tcfg, tp))
    return {"out_dir": str(out), "n_sites": len(tp.site_t_ns), "n_pairs": len(tp.captures),
            "path_length_m": float(tp.site_s_m[-1]), "duration_s": (traj.t1_ns - traj.t0_ns) * 1e-9,
            "map_png": str(out / "map.png")}


def metadata(config, tcfg, tp) -> dict:
    """``metadata.yaml`` content of a traverse (``kind: traverse``)."""
    head = MastHead.from_rig(config.rig)
    return {"generator": "vo-testbed", "kind": "traverse", "version": __version__, "config": config.to_dict(),
            "traverse": to_mapping(tcfg), "seed": config.seed, "rig": rig_to_dict(config.rig),
            "mast": {"T_b_mast": head.T_b_mast, "T_head_c": head.T_head_c, "tilt0_rad": head.tilt0_rad},
            "n_sites": int(len(tp.site_t_ns)), "site_arc_length_m": tp.site_s_m,
            "dead_reckoning": {"filter": "sim.sensors.deadreckoning EKF", "imu_rate_hz": DR_RATE_HZ}}


def dead_reckoning(tp, tcfg, config, imu, ticks, enc):
    """Per-site dead-reckoning pose (S,4,4) and covariance (S,6,6): the rover's EKF
    (:mod:`sim.sensors.deadreckoning`) on the written sensors (``imu``, wheel ``ticks`` of encoder ``enc``),
    the IMU block-averaged to :data:`DR_RATE_HZ` (averaging keeps the integrated angle and the white-noise
    density), started from the true initial pose. Its white slip noise is the random part of the slip model
    (``traverse.slip_random_std``); the mean slip is not corrected (an on-board filter does not know it) but is
    in its covariance: a slip-bias state of prior std ``traverse.slip`` (at least 0.02); the gyro and
    accelerometer bias random walks are the rig IMU's."""
    n = max(1, int(round(config.rig.imu.rate_hz / DR_RATE_HZ)))
    m = (len(imu.t_ns) - 1) // n * n + 1
    blocks = lambda a: np.vstack([a[:1], a[1:m].reshape(-1, n, 3).mean(axis=1)])  # noqa: E731
    dec = ImuSamples(imu.t_ns[:m:n], blocks(imu.gyro), blocks(imu.accel))
    cfg = DeadReckoningConfig(enc.wheel_radius, enc.ticks_per_rev, gyro_noise_density=config.rig.imu.gyro_noise_density,
                              slip_std=max(tcfg.slip_random_std, 1e-4), slip_bias_std=max(tcfg.slip, 0.02),
                              gyro_bias_walk=config.rig.imu.gyro_random_walk,
                              accel_bias_walk=config.rig.imu.accel_random_walk)
    T_w_b0 = tp.trajectory.states(np.array([tp.trajectory.t0_ns])).T_w_b[0]
    T_i_b = np.linalg.inv(config.rig.imu.T_b_i_array)
    dr = dead_reckon(dec, ticks, T_i_b[:3, :3].T, T_w_b0, np.diag([1e-8] * 6), cfg)
    return dr.at(np.clip(tp.site_t_ns, dr.t_ns[0], dr.t_ns[-1]))


def render_sites(tp, config, writer: TraverseWriter, T_dr, C_dr, progress: bool, threads: int | None) -> None:
    """Render every capture of ``tp`` at the true mast angles (the rover itself not drawn: at a low sun its
    shadow on a 1024-texel map over 80 m is blocky); grey conversion, image noise and the PNGs on the frame
    loop's workers; a site's ``site.yaml`` once its last pair is committed."""
    from sim.render import StereoRenderer        # mujoco
    from sim.world import build_world
    head = MastHead.from_rig(config.rig)
    sigma = 0.0 if config.ideal else config.noise.image_sigma
    n_pairs = np.bincount([c.site for c in tp.captures], minlength=len(tp.site_t_ns))
    pairs = {k: [] for k in range(len(tp.site_t_ns))}
    world = build_world(tp.scene, config.rig, vehicle="rover")

    def commit(c, record):
        pairs[c.site].append(record)
        if len(pairs[c.site]) == n_pairs[c.site]:
            k = c.site
            writer.write_site(k, int(tp.site_t_ns[k]), float(tp.site_s_m[k]), tp.T_w_b_sites[k], T_dr[k], C_dr[k],
                              pairs.pop(k))

    with StereoRenderer(world, config.rig, supersample=config.render.supersample, show_vehicle=False) as cam, \
            FrameLoop(len(tp.captures), "panoramas", threads, progress) as loop:
        for c in sorted(tp.captures, key=lambda c: c.site):       # stable: a site's pairs in order
            head.set_pointing(world, c.pan_true, c.tilt_true)
            rendered = cam.render(tp.T_w_b_sites[c.site]).images[:2]

            def work(c=c, rendered=rendered):
                images = add_noise([to_gray(img) for img in rendered], sigma,
                                   indexed_stream(config.seed, "image_noise", c.site * 100 + c.pair))
                return writer.write_pair(c, images)

            loop.submit(work, lambda record, c=c: commit(c, record))
