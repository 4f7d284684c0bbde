"""Generate a synthetic dataset: trajectory -> IMU -> rendering -> writers, streamed to disk.

``generate(config, out_dir)`` is what ``vo-testbed generate`` calls. Random streams are
separate per sensor (``sim.rng``), so turning images off does not change the IMU noise.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigs.records import Gcp
from rigs.rig_yaml import rig_to_dict
from rigs.typed_config import to_mapping
from scenes.plot import plot_topdown
from scenes.registry import make_scene
from sim.errors import SimError
from sim.frame_pipeline import FrameLoop
from sim.generate_config import GenerateConfig
from sim.motion import VehicleTrajectory
from sim.render_workers import ChunkSource, check_splittable, device_label
from sim.replay import ReplayTrajectory
from sim.rng import indexed_stream, scene_streams, stream
from sim.sensors.calib_error import perturb_rig
from sim.sensors.camera import FrameExposer, StereoCamera, add_noise
from sim.sensors.effects_timing import frame_stamps_ns
from sim.sensors.effects_truth import time_offset_ns, write_calibration_truth, write_frame_effects
from sim.sensors.imu import imu_times_ns, measure
from sim.sensors.imu_noise import add_imu_noise
from sim.sensors.wheels import measure_wheels, with_vehicle_geometry
from sim.stage_timer import NO_TIMER
from sim.vehicles import vehicle_class
from sim.version import __version__
from sim.world_cache import world_cache
from sim.writers import DatasetWriters
from sim.writers.fanout import check_bag_export
from sim.writers.common import PngOptions, claim_folder

CLEARANCE_M = 0.5                  # margin around the vehicle's footprint that no actor may enter
CLEARANCE_STEP_NS = 50_000_000     # the clearance check's time step (50 ms)


@dataclass(frozen=True)
class GenerateResult:
    out_dir: str
    n_frames: int
    n_imu: int
    duration_s: float
    path_length_m: float
    topdown_png: str
    formats: tuple
    notes: tuple = ()            # what differs from the request (e.g. a duration longer than the route)
    replay_departure: dict = None   # --motion FILE: the spline's departure from the poses (sim.replay.Departure)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclass
class Setup:
    """Everything resolved from a config: rig, scene, trajectory and sample times."""

    config: GenerateConfig
    rig: object
    scene: object
    trajectory: object
    frame_t_ns: np.ndarray
    imu_t_ns: np.ndarray
    image_noise: float           # sigma actually applied (grey levels; 0 when ideal)
    motion: object = None        # config.motion (sim.motion.MotionConfig)
    supersample: int = 1         # config.render.supersample (sim.render)
    frame_stamp_ns: np.ndarray = None   # written frame stamps: frame_t_ns + jitter (camera.timestamp_jitter_us)


def resolve(config: GenerateConfig) -> Setup:
    """Build scene and trajectory from the typed config; compute frame and IMU times."""
    rig, scene_cfg = config.rig, config.scene_config
    scene = make_scene(scene_cfg, scene_streams(scene_cfg.seed), stream(config.seed, "dynamic"))
    if config.replay.file:                   # --motion FILE: the recorded poses through a spline (sim.replay)
        traj = ReplayTrajectory.from_config(config.replay, rig, config.motion.start_time_ns, config.duration_s,
                                            scene)
    else:
        traj = VehicleTrajectory.from_route(scene.route, scene.ground_height, config.motion,
                                            stream(config.seed, "motion"), duration_s=config.duration_s)
    check_clearance(scene, traj, config)
    period_ns = int(round(1e9 / rig.camera_rate_hz))
    frame_t = np.arange(traj.t0_ns, traj.t1_ns + 1, period_ns, dtype=np.int64)
    imu_t = imu_times_ns(traj.t0_ns, traj.t1_ns, rig.imu.rate_hz)
    noise = 0.0 if config.ideal else config.noise.image_sigma
    stamps = frame_stamps_ns(frame_t, config.camera.timestamp_jitter_us, stream(config.seed, "timestamp_jitter"))
    return Setup(config, rig, scene, traj, frame_t, imu_t, noise, config.motion, config.render.supersample, stamps)


def check_clearance(scene, trajectory, config: GenerateConfig) -> None:
    """Raise a one-line SimError when the vehicle's footprint, grown by :data:`CLEARANCE_M`, touches one of
    the scene's actors at any :data:`CLEARANCE_STEP_NS` step of ``trajectory`` (e.g. a cruise speed that
    drives the car into the traffic ahead, which a scene places for its default motion)."""
    t = np.arange(trajectory.t0_ns, trajectory.t1_ns + 1, CLEARANCE_STEP_NS, dtype=np.int64)
    x_c, half_l, half_w = vehicle_class(config.vehicle)(config.rig).footprint()
    hit = scene.first_contact(t, trajectory.states(t).T_w_b, (x_c, half_l + CLEARANCE_M, half_w + CLEARANCE_M))
    if hit is not None:
        t_hit, actor_id, kind = hit
        key = "motion.cruise_speed_mps" if config.motion.cruise_speed_mps > 0 else "motion"
        raise SimError(f"{key}: the vehicle reaches {config.scene.name} actor {actor_id} ({kind}) "
                       f"{(t_hit - trajectory.t0_ns) * 1e-9:.1f} s after the start; the scene's traffic is "
                       f"placed for its default motion (choose a lower cruise speed or another start)")


def imu_streams(setup: Setup):
    """The measured IMU samples of ``setup`` and the true biases (:func:`measured_imu`)."""
    return measured_imu(setup.trajectory.states(setup.imu_t_ns), setup.rig.imu, setup.config.seed,
                        setup.config.ideal)


def measured_imu(states, imu, seed: int, ideal: bool = False):
    """The measured (noisy unless ``ideal``) IMU samples at the times of trajectory ``states`` and the true
    biases: the IMU sensor's clean measurement, then its noise step (streams ``imu_white``, ``imu_bias``)."""
    clean = measure(states, imu)
    if ideal:
        imu = dataclasses.replace(imu, accel_noise_density=0.0, gyro_noise_density=0.0,
                                  accel_random_walk=0.0, gyro_random_walk=0.0)
    return add_imu_noise(clean, imu, stream(seed, "imu_white"), stream(seed, "imu_bias"))


def truth_records(setup: Setup, biases):
    """IMU-frame ground truth at IMU times, cam0 poses at frame times, and the GCPs."""
    rig, traj = setup.rig, setup.trajectory
    T_b_i = rig.imu.T_b_i_array
    s = traj.states(setup.imu_t_ns)
    T_w_i = s.T_w_b @ T_b_i
    lever_w = np.einsum("nij,j->ni", s.T_w_b[:, :3, :3], T_b_i[:3, 3])
    omega_w = np.einsum("nij,nj->ni", s.T_w_b[:, :3, :3], s.omega_b)
    v_w_i = s.v_w + np.cross(omega_w, lever_w)
    T_w_b_frames = traj.states(setup.frame_t_ns).T_w_b
    T_w_c0 = T_w_b_frames @ rig.cameras[0].T_b_c_array
    sites = setup.scene.gcp_sites
    gcps = []
    if sites:
        xy = np.array([[g.x, g.y] for g in sites])
        t_pass = traj.pass_times_ns(xy)
        T_pass = traj.states(t_pass).T_w_b
        for g, t, T in zip(sites, t_pass, T_pass):
            if not setup.frame_t_ns[0] <= t <= setup.frame_t_ns[-1]:
                continue    # not reached within the simulated duration
            ground = np.array([g.x, g.y, float(setup.scene.ground_height(g.x, g.y))])
            p_c0 = (T @ rig.cameras[0].T_b_c_array)[:3, 3]
            gcps.append(Gcp(g.name, int(t), ground, p_c0))
    return dict(T_w_i=T_w_i, v_w_i=v_w_i, T_w_b_frames=T_w_b_frames, T_w_c0=T_w_c0, gcps=gcps, biases=biases)


def metadata(setup: Setup) -> dict:
    """``metadata.yaml`` content: ``config`` is the resolved configuration (its hash is ``config_hash``);
    ``scene``, ``rig`` and ``image_noise_sigma`` are what the data were made with (scene seed resolved,
    the rig's wheels those of the vehicle, sigma 0 when ideal)."""
    import mujoco
    c = setup.config
    return {
        "generator": "vo-testbed", "version": __version__, "mujoco": mujoco.__version__,
        "config": c.to_dict(), "config_hash": c.config_hash(), "seed": c.seed,
        "scene": to_mapping(setup.scene.config), "rig": rig_to_dict(setup.rig),
        "image_noise_sigma": setup.image_noise,
        "n_frames": int(len(setup.frame_t_ns)) if c.images else 0, "n_imu": int(len(setup.imu_t_ns)),
        "path_length_m": float(setup.trajectory.path_length()),
        "duration_s": generated_duration_s(setup),
        **({"duration_note": note} if (note := duration_note(setup)) else {}),
        **({"replay": setup.trajectory.metadata()} if c.replay.file else {}),
    }


def generated_duration_s(setup: Setup) -> float:
    """Seconds actually simulated (the requested ``duration_s`` ends at the end of the route)."""
    return (setup.trajectory.t1_ns - setup.trajectory.t0_ns) * 1e-9


def duration_note(setup: Setup):
    """A line when the requested ``duration_s`` is longer than the route (None otherwise)."""
    asked, done = setup.config.duration_s, generated_duration_s(setup)
    if asked is None or asked <= done + 1e-6:
        return None
    return (f"duration_s: {asked:g} s asked for, but the route of {setup.config.scene.name} ends after "
            f"{done:.3f} s; {done:.3f} s were generated (metadata.yaml duration_s)")


def _formats(fmt: str) -> tuple:
    return ("euroc", "kitti") if fmt == "both" else (fmt,)


def render_frames(setup: Setup, T_w_b_frames, writers, progress: bool = True, start: int = 0,
                  threads: int | None = None, timer=None, workers: int = 1, scheduler: str | None = None,
                  egl_devices=()):
    """Measure every stereo frame at ``T_w_b_frames`` (N,4,4) with the camera sensor, add frame ``k``'s
    image noise (stream ``image_noise``, index k), stream to the writers from frame ``start`` on, stamped
    ``setup.frame_stamp_ns``. With image effects (``camera.*``) frames go through
    :class:`sim.sensors.camera.FrameExposer`; returns the auto exposure gains then (None otherwise).

    Rendering runs on this thread (it owns the GL context); each frame's noise, effects after the
    auto exposure, PNG encoding and writing run in a :class:`sim.frame_pipeline.FramePipeline` of
    ``threads`` workers (None: one per CPU; 0: inline), committed in frame order: the bytes do not depend
    on ``threads``. ``timer`` (:class:`sim.stage_timer.StageTimer`) gets the stages ``render`` (with
    read-back), ``read-back``, ``noise/effects``, ``rectify`` (KITTI), ``encode`` and ``write``, and ``frame loop`` and
    ``frame loop CPU``, the loop's elapsed and process CPU time.

    ``workers > 1`` or a Dask ``scheduler``: frame ranges are rendered (noise and effects included) in
    other processes, each with its own GL context (:mod:`sim.render_workers`; ``egl_devices`` spread them
    over GPUs), and written here in order, byte-identical. ``metadata.yaml`` records under ``rendering``
    the GL renderer(s) that drew the frames of this run."""
    if workers > 1 or scheduler:
        return _render_frames_in_workers(setup, writers, progress, start, threads, timer, workers, scheduler,
                                         egl_devices)

    c = setup.config
    timer = timer or NO_TIMER
    effects = c.camera.image_effects
    first = 0 if effects and c.camera.auto_exposure else start   # auto exposure: gains from frame 0 on
    gains = [1.0] * len(setup.frame_t_ns)
    pose_at = lambda t_ns: setup.trajectory.states(t_ns).T_w_b  # noqa: E731
    t0, c0 = time.perf_counter(), time.process_time()
    world, source = world_cache().world(c, setup.scene, setup.rig, c.vehicle)   # the machine's cache, or built
    for name, value in (("world build", time.perf_counter() - t0), ("world build CPU", time.process_time() - c0),
                        ("world cache " + source, 1.0)):
        timer.add(name, value)
    with StereoCamera(setup.scene, setup.rig, vehicle=c.vehicle, depth=c.depth, segmentation=c.segmentation,
                      supersample=setup.supersample, rgb=c.rgb, timer=timer, world=world) as camera:
        if c.segmentation:
            writers.add_segmentation_ids(setup.scene.segmentation_rows(camera.geom_names()))
        writers.add_metadata({"rendering": [device_label(camera.gl_renderer)]})
        exposer = FrameExposer(camera, setup.rig, c.camera, 1.0 / setup.rig.camera_rate_hz, c.seed,
                               setup.image_noise, noisy=not c.ideal) if effects else None
        with FrameLoop(len(setup.frame_t_ns), "render", threads, progress, start, timer) as loop:
            for k in range(first, len(setup.frame_t_ns)):
                with timer.stage("render"):
                    if exposer is None:
                        images, depth, seg = camera.measure(T_w_b_frames[k],
                                                            setup.scene.actor_states(int(setup.frame_t_ns[k])))
                    else:
                        images, depth, seg, gains[k] = exposer.render(k, int(setup.frame_t_ns[k]), pose_at,
                                                                      setup.scene.actor_states)
                if k < start:                   # on disk already (auto exposure replays from frame 0)
                    continue
                t_ns = int(setup.frame_stamp_ns[k])

                def work(k=k, t_ns=t_ns, images=images, depth=depth, seg=seg):
                    with timer.stage("noise/effects"):
                        if exposer is None:
                            out = add_noise(images, setup.image_noise, indexed_stream(c.seed, "image_noise", k))
                        else:
                            out = exposer.finish(k, images, gains[k])
                    writers.write_frame_files(k, t_ns, out, depth=depth, seg=seg, timer=timer)

                loop.submit(work, _row_commit(writers, t_ns))
    return gains if effects else None


def _row_commit(writers, t_ns: int):
    """A frame's commit: its CSV rows and progress marker, written after its files exist."""
    return lambda _: writers.add_frame(t_ns, files_written=True)


def _render_frames_in_workers(setup: Setup, writers, progress, start, threads, timer, workers, scheduler,
                              egl_devices) -> None:
    """:func:`render_frames` with the frames rendered by :class:`sim.render_workers.ChunkSource`."""
    c = setup.config
    timer = timer or NO_TIMER
    n = len(setup.frame_t_ns)
    devices, ids_written = [], not c.segmentation
    t0, first_s, first_worker_s = time.perf_counter(), 0.0, 0.0
    png = PngOptions.of(c.render) if c.format == "euroc" else None    # EuRoC images: encoded by the workers
    resolved = dataclasses.replace(setup, rig=c.rig)          # as resolve(c) made it: the rig the workers load
    with ChunkSource(c, workers, resolve, scheduler, egl_devices, png, setup=resolved) as source, \
            FrameLoop(n, "render", threads, progress, start, timer) as loop:
        for name, seconds in (("world build", source.build_s), ("world build CPU", source.build_cpu_s),
                              ("frame loop", source.build_s), ("frame loop CPU", source.build_cpu_s),
                              ("world cache " + getattr(source.handoff, "source", "off"), 1.0)):
            timer.add(name, seconds)                   # the world built here for the worker processes
        for chunk in source.chunks(start, n):
            if not ids_written:
                writers.add_segmentation_ids(setup.scene.segmentation_rows(chunk.geom_names))
                ids_written = True
            if chunk.device not in devices:
                devices.append(chunk.device)
            if not first_s:
                first_s = time.perf_counter() - t0
                timer.add("first chunk", first_s)
                timer.add("first chunk frames", len(chunk.frames))
            if not chunk.here and not first_worker_s:
                first_worker_s = time.perf_counter() - t0
                timer.add("first worker chunk", first_worker_s)
            timer.add("frames here", len(chunk.frames) if chunk.here else 0)
            for name, seconds in chunk.stage_s.items():
                timer.add(name, seconds)
            timer.add_max("worker peak MB", chunk.peak_rss_mb)
            for j, (images, depth, seg) in enumerate(chunk.frames):
                k = chunk.start + j
                t_ns = int(setup.frame_stamp_ns[k])

                def work(k=k, t_ns=t_ns, images=images, depth=depth, seg=seg):
                    writers.write_frame_files(k, t_ns, images, depth=depth, seg=seg, timer=timer)

                loop.submit(work, _row_commit(writers, t_ns))
    writers.add_metadata({"rendering": sorted(devices)})
    return None


def wheel_odometry(setup: Setup, dims):
    """Encoder ticks of the rig's wheels on a vehicle with ``dims`` at ``rig.wheels.rate_hz`` (stream ``wheels``)."""
    enc = setup.rig.wheels
    t_ns = np.arange(setup.trajectory.t0_ns, setup.trajectory.t1_ns + 1, int(round(1e9 / enc.rate_hz)), dtype=np.int64)
    return measure_wheels(setup.trajectory, dims, enc, t_ns, stream(setup.config.seed, "wheels"))


def generate(config: GenerateConfig, out_dir, progress: bool = True, overwrite: bool = False,
             threads: int | None = None, timer=None, workers: int = 1, scheduler: str | None = None,
             egl_devices=(), bag_export=None) -> GenerateResult:
    """Generate the dataset described by ``config`` into ``out_dir``.

    The folder is locked for the whole run (:func:`sim.writers.common.claim_folder`): a second writer gets
    a one-line error naming this process. It carries an ``INCOMPLETE`` marker until everything is written,
    bags included; an interrupted run is resumed by calling ``generate`` again with the same config
    (frames already on disk are skipped; the result is byte-identical to an uninterrupted run).
    ``overwrite`` deletes a dataset of ours (marked :data:`sim.writers.common.OWNER`), never anything else.
    ``threads``, ``timer``, ``workers``, ``scheduler`` and ``egl_devices``: as :func:`render_frames` (the
    bytes do not depend on them, but for ``metadata.yaml``'s ``rendering``, the renderer that drew the frames).
    ``bag_export``: the converter of a ``rosbag1``/``rosbag2`` format (:func:`sim.app.rosbag_export.export_rosbag`:
    it lives in the app layer, because it reads the finished folder through the reader API).
    """
    check_bag_export(config.format, bag_export)     # before anything is written
    world_cache()                                   # its settings (VO_TESTBED_WORLD_CACHE_MB) too
    if workers > 1 or scheduler:
        check_splittable(config)
    with claim_folder(out_dir, overwrite):
        return _generate(config, Path(out_dir), progress, threads, timer, workers, scheduler, egl_devices,
                         bag_export)


def _generate(config: GenerateConfig, out_dir: Path, progress: bool, threads=None, timer=None, workers: int = 1,
              scheduler=None, egl_devices=(), bag_export=None) -> GenerateResult:
    """:func:`generate` in a folder this process has claimed."""
    out_dir = Path(out_dir)
    setup = resolve(config)
    dims = vehicle_class(config.vehicle).dims
    if setup.rig.wheels is not None:     # the calibration written is the geometry the ticks are made with
        setup = dataclasses.replace(setup, rig=dataclasses.replace(
            setup.rig, wheels=with_vehicle_geometry(setup.rig.wheels, dims)))
    noisy, biases = imu_streams(setup)
    truth = truth_records(setup, biases)
    # calib_error: the images use setup.rig, the files written for estimators the perturbed rig
    written_rig, calib_draws = perturb_rig(setup.rig, config.calib_error, stream(config.seed, "calib_error"))
    writers = DatasetWriters(out_dir, written_rig, metadata(setup), fmt=config.format, depth=config.depth,
                             segmentation=config.segmentation, depth_format=config.depth_format,
                             png=PngOptions.of(config.render), bag_export=bag_export)
    start = writers.resumed_frames      # > 0 when resuming an interrupted run of the same config
    # IMU and ground truth are replayed in full; the writers skip rows already on disk
    writers.add_imu(noisy.t_ns + time_offset_ns(config), noisy.gyro, noisy.accel)   # t_imu = t_cam + td
    writers.add_groundtruth(setup.imu_t_ns, truth["T_w_i"], truth["v_w_i"], biases.b_g, biases.b_a)
    writers.add_cam0_truth(setup.frame_stamp_ns, truth["T_w_c0"])
    write_calibration_truth(out_dir, setup.rig, calib_draws, config)
    writers.add_gcps(truth["gcps"])
    actors = setup.scene.actor_truth(setup.frame_t_ns)
    if actors:
        writers.add_actors(setup.frame_t_ns, actors)
    if setup.rig.wheels is not None:
        writers.add_wheels(wheel_odometry(setup, dims))
    if config.images:
        gains = render_frames(setup, truth["T_w_b_frames"], writers, progress=progress, start=start,
                              threads=threads, timer=timer, workers=workers, scheduler=scheduler,
                              egl_devices=egl_devices)
        write_frame_effects(out_dir, setup, gains)
    png = str(out_dir / "topdown.png")
    write_topdown(setup, truth, png)
    writers.finalize()
    return GenerateResult(str(out_dir), int(len(setup.frame_t_ns)) if config.images else 0,
                          int(len(setup.imu_t_ns)), (setup.trajectory.t1_ns - setup.trajectory.t0_ns) * 1e-9,
                          float(setup.trajectory.path_length()), png, _formats(config.format),
                          tuple(filter(None, [duration_note(setup)])),
                          setup.trajectory.departure.to_dict() if config.replay.file else None)


def write_topdown(setup: Setup, truth: dict, path: str) -> None:
    """Top-down PNG of the scene, the route actually driven and the GCPs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rigs.figures import save_figure

    fig, ax = plt.subplots(figsize=(8, 7))
    xy = truth["T_w_c0"][:, :2, 3]
    plot_topdown(setup.scene, ax, route_xy=xy)
    ax.set_title(f"{setup.config.scene.name} / {setup.config.rig.name} / seed {setup.config.seed}")
    save_figure(fig, path)
