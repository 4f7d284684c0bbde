"""Generate a synthetic dataset: trajectory -> IMU -> rendering -> writers, streamed to disk.

``generate(config, out_dir)`` is what ``vo-testbed generate`` calls. Random streams are
separate per sensor (``sim.rng``), so turning images off does not change the IMU noise.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.config import GenerateConfig
from sim.errors import SimError
from sim.rng import indexed_stream, stream


@dataclass(frozen=True)
class GenerateResult:
    out_dir: str
    n_frames: int
    n_imu: int
    duration_s: float
    path_length_m: float
    topdown_png: str
    formats: tuple

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
    image_noise: float
    motion: object = None        # the resolved sim.motion.MotionConfig
    supersample: int = 1         # render.supersample override (sim.render)


def resolve(config: GenerateConfig) -> Setup:
    """Build rig, scene and trajectory; compute frame and IMU times."""
    from rigs.overrides import apply_overrides
    from rigs.presets import get_rig
    from scenes.base import SceneConfig
    from scenes.registry import make_scene
    from sim.imu import imu_times_ns
    from sim.motion import MotionConfig, VehicleTrajectory

    ov = config.split_overrides()
    rig = apply_overrides(get_rig(config.rig), ov["rig"])
    try:
        scene_cfg = SceneConfig(name=config.scene, seed=config.seed, **ov["scene"])
        motion_cfg = MotionConfig(**ov["motion"])
    except TypeError as e:
        raise SimError(f"overrides: {e}") from None
    scene = make_scene(scene_cfg)
    traj = VehicleTrajectory.from_route(scene.route, scene.ground_height, motion_cfg,
                                        stream(config.seed, "motion"), duration_s=config.duration_s)
    period_ns = int(round(1e9 / rig.camera_rate_hz))
    frame_t = np.arange(traj.t0_ns, traj.t1_ns + 1, period_ns, dtype=np.int64)
    imu_t = imu_times_ns(traj.t0_ns, traj.t1_ns, rig.imu.rate_hz)
    noise = ov["image_noise"] if ov["image_noise"] is not None else config.image_noise
    return Setup(config, rig, scene, traj, frame_t, imu_t, 0.0 if config.ideal else noise, motion_cfg,
                 ov["supersample"])


def imu_streams(setup: Setup):
    """Exact IMU samples, the measured (noisy unless ideal) samples and the true biases."""
    from sim.imu import measure_imu
    from sim.imu_noise import add_imu_noise

    rig, seed = setup.rig, setup.config.seed
    clean = measure_imu(setup.trajectory, rig.imu, setup.imu_t_ns)
    imu = rig.imu
    if setup.config.ideal:
        imu = dataclasses.replace(imu, accel_noise_density=0.0, gyro_noise_density=0.0,
                                  accel_random_walk=0.0, gyro_random_walk=0.0)
    return add_imu_noise(clean, imu, stream(seed, "imu_white"), stream(seed, "imu_bias"))


def truth_records(setup: Setup, biases):
    """IMU-frame ground truth at IMU times, cam0 poses at frame times, and the GCPs."""
    from vo.dataset.types import Gcp

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
    from rigs.io_yaml import rig_to_dict
    from sim import __version__
    import mujoco
    c = setup.config
    return {
        "generator": "vo-testbed", "version": __version__, "mujoco": mujoco.__version__,
        "config": c.to_dict(), "config_hash": c.config_hash(), "seed": c.seed,
        "scene": dataclasses.asdict(setup.scene.config), "rig": rig_to_dict(setup.rig),
        "motion": _plain(dataclasses.asdict(setup.motion)) if setup.motion is not None else {},
        "image_noise_sigma": setup.image_noise,
        "n_frames": int(len(setup.frame_t_ns)) if c.images else 0, "n_imu": int(len(setup.imu_t_ns)),
        "path_length_m": float(setup.trajectory.path_length()),
    }


def _plain(d: dict) -> dict:
    """Tuples -> lists so the metadata YAML stays plain."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


def _formats(fmt: str) -> tuple:
    return ("euroc", "kitti") if fmt == "both" else (fmt,)


def render_frames(setup: Setup, T_w_b_frames, writers, progress: bool = True, start: int = 0) -> None:
    """Render every stereo frame at ``T_w_b_frames`` (N,4,4), add noise, convert to grey, stream to the writers
    (lens distortion is already applied by the renderer)."""
    import cv2
    from tqdm import tqdm
    from sim.image_noise import add_image_noise
    from sim.world import build_world
    from sim.render import StereoRenderer

    c, rig = setup.config, setup.rig
    world = build_world(setup.scene, rig, vehicle=c.vehicle)
    with StereoRenderer(world, rig, depth=c.depth, segmentation=c.segmentation,
                        supersample=setup.supersample) as renderer:
        bar = tqdm(total=len(setup.frame_t_ns), initial=start, desc="render", unit="pair",
                   disable=not progress, dynamic_ncols=True)
        for k, t_ns in enumerate(setup.frame_t_ns):
            if k < start:
                continue
            rng = indexed_stream(c.seed, "image_noise", k)
            fr = renderer.render(T_w_b_frames[k])
            images = []      # the renderer already applied lens distortion (exact inverse map)
            for img in fr.images[:2]:
                if img.ndim == 3 and not c.rgb:
                    img = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
                if setup.image_noise > 0:
                    img = add_image_noise(img, setup.image_noise, rng)
                images.append(img)
            writers.add_frame(int(t_ns), images, depth=fr.depth, seg=fr.seg)
            bar.update(1)
        bar.close()


def generate(config: GenerateConfig, out_dir, progress: bool = True, overwrite: bool = False) -> GenerateResult:
    """Generate the dataset described by ``config`` into ``out_dir``.

    The folder carries an ``INCOMPLETE`` marker until everything is written; an interrupted
    run is resumed by calling ``generate`` again with the same config (frames already on disk
    are skipped; the result is byte-identical to an uninterrupted run).
    """
    from sim.dataset import DatasetWriters

    out_dir = Path(out_dir)
    setup = resolve(config)
    noisy, biases = imu_streams(setup)
    truth = truth_records(setup, biases)
    writers = DatasetWriters(out_dir, setup.rig, metadata(setup), fmt=config.format, depth=config.depth,
                             segmentation=config.segmentation, overwrite=overwrite)
    start = writers.resumed_frames      # > 0 when resuming an interrupted run of the same config
    # IMU and ground truth are replayed in full; the writers skip rows already on disk
    writers.add_imu(noisy.t_ns, noisy.gyro, noisy.accel)
    writers.add_groundtruth(setup.imu_t_ns, truth["T_w_i"], truth["v_w_i"], biases.b_g, biases.b_a)
    writers.add_cam0_truth(setup.frame_t_ns, truth["T_w_c0"])
    writers.add_gcps(truth["gcps"])
    if setup.rig.wheels is not None:
        from sim.wheels import measure_wheels
        wheel_t = np.arange(setup.trajectory.t0_ns, setup.trajectory.t1_ns + 1,
                            int(round(1e9 / setup.rig.wheels.rate_hz)), dtype=np.int64)
        writers.add_wheels(measure_wheels(setup.trajectory, setup.rig.wheels, wheel_t, stream(config.seed, "wheels")))
    if config.images:
        render_frames(setup, truth["T_w_b_frames"], writers, progress=progress, start=start)
    png = str(out_dir / "topdown.png")
    write_topdown(setup, truth, png)
    writers.finalize()
    return GenerateResult(str(out_dir), int(len(setup.frame_t_ns)) if config.images else 0,
                          int(len(setup.imu_t_ns)), (setup.trajectory.t1_ns - setup.trajectory.t0_ns) * 1e-9,
                          float(setup.trajectory.path_length()), png, _formats(config.format))


def write_topdown(setup: Setup, truth: dict, path: str) -> None:
    """Top-down PNG of the scene, the route actually driven and the GCPs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scenes.plot import plot_topdown
    from vo.eval.plots import save_figure

    fig, ax = plt.subplots(figsize=(8, 7))
    xy = truth["T_w_c0"][:, :2, 3]
    plot_topdown(setup.scene, ax, route_xy=xy)
    ax.set_title(f"{setup.config.scene} / {setup.config.rig} / seed {setup.config.seed}")
    save_figure(fig, path)
