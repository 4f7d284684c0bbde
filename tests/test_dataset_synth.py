"""Synthetic inputs shared by the dataset tests (tests/ is on sys.path under pytest's prepend mode),
plus the checks that the synthetic rig/motion are what the other tests assume."""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from rigs.model import Camera, Imu, Rig
from rigs.records import Gcp
from rigs.geometry import make_T, rot_x, rot_z

R_B_C_FORWARD = np.array([[0.0, 0, 1], [-1, 0, 0], [0, -1, 0]])
W, H = 64, 48
T0_NS = 1_403_636_579_763_555_584          # a real EuRoC-sized epoch: needs full int64
FRAME_DT_NS = 50_000_000
IMU_DT_NS = 5_000_000


def make_rig(parallel: bool = True) -> Rig:
    """64x48 stereo pair, f = 50 px, baseline 0.27 m; IMU rotated/offset from the body."""
    T_b_c0 = make_T(R_B_C_FORWARD, (0.3, 0.135, 1.2))
    R_c0_c1 = np.eye(3) if parallel else rot_x(0.01) @ rot_z(-0.02)
    T_b_c1 = T_b_c0 @ make_T(R_c0_c1, (0.27, 0.0, 0.0))
    cams = tuple(Camera(f"cam{k}", W, H, 50.0, 50.0, 31.5, 23.5, T_b_c=T) for k, T in enumerate((T_b_c0, T_b_c1)))
    imu = Imu("test-imu", 200.0, 2e-3, 1.7e-4, 3e-3, 1.9e-5, T_b_i=make_T(rot_z(0.1), (0.2, 0.0, 1.0)))
    return Rig("synth", cams, imu, camera_rate_hz=20.0, mount="test")


def T_w_b_at(t_ns: np.ndarray) -> np.ndarray:
    """(N,4,4) smooth planar motion: 1 m/s forward along a gentle left turn (0.2 rad/s)."""
    s = (np.asarray(t_ns, dtype=np.int64) - T0_NS) * 1e-9
    T = np.tile(np.eye(4), (len(s), 1, 1))
    yaw = 0.2 * s
    T[:, :3, :3] = [rot_z(a) for a in yaw]
    T[:, 0, 3], T[:, 1, 3] = np.sin(yaw) / 0.2, (1 - np.cos(yaw)) / 0.2
    return T


class Synth:
    """5 stereo frames of random 64x48 images, 50 IMU samples, gt at every IMU sample, 2 GCPs."""

    def __init__(self, seed: int = 7, n_frames: int = 5, rgb: bool = False):
        rng = np.random.default_rng(seed)
        self.rig = make_rig()
        self.t_frames = T0_NS + FRAME_DT_NS * np.arange(n_frames, dtype=np.int64)
        shape = (H, W, 3) if rgb else (H, W)
        self.images = [[rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(2)] for _ in range(n_frames)]
        self.t_imu = T0_NS + IMU_DT_NS * np.arange(10 * n_frames, dtype=np.int64)
        self.gyro = rng.normal(0, 0.1, (len(self.t_imu), 3))
        self.accel = rng.normal(0, 1.0, (len(self.t_imu), 3)) + [0, 0, 9.81]
        self.T_w_i = T_w_b_at(self.t_imu) @ self.rig.imu.T_b_i_array
        self.v_w = rng.normal(0, 1, (len(self.t_imu), 3))
        self.b_g = rng.normal(0, 1e-3, (len(self.t_imu), 3))
        self.b_a = rng.normal(0, 1e-2, (len(self.t_imu), 3))
        self.T_w_c0 = T_w_b_at(self.t_frames) @ self.rig.cameras[0].T_b_c_array
        self.gcps = [Gcp("G1", int(self.t_frames[1]), np.array([0.1, 0.2, 0.0]), self.T_w_c0[1, :3, 3].copy()),
                     Gcp("G2", int(self.t_frames[-1]), np.array([0.3, 0.5, -0.01]), self.T_w_c0[-1, :3, 3].copy())]
        self.depth = [np.abs(rng.normal(5, 1, (H, W))).astype(np.float32) for _ in range(n_frames)]
        self.seg = [np.stack([rng.integers(-1, 300, (H, W)), rng.integers(0, 2, (H, W))], axis=-1)
                    for _ in range(n_frames)]
        self.metadata = {"scene": {"name": "synthetic", "seed": seed}, "seed": seed,
                         "imu": {"noise": "none"}, "versions": {"testbed": "0.1.0"}}

    def write(self, writer, frames=None, with_depth=False, with_seg=False, finalize=True):
        """Feed everything to ``writer`` (IMU/gt interleaved per frame, as a generator would)."""
        frames = range(len(self.t_frames)) if frames is None else frames
        for k in frames:
            sl = slice(10 * k, 10 * (k + 1))
            writer.add_imu(self.t_imu[sl], self.gyro[sl], self.accel[sl])
            writer.add_groundtruth(self.t_imu[sl], self.T_w_i[sl], self.v_w[sl], self.b_g[sl], self.b_a[sl])
            writer.add_frame(self.t_frames[k], self.images[k], depth=[self.depth[k], None] if with_depth else None,
                             seg=self.seg[k] if with_seg else None)
            writer.add_cam0_truth(self.t_frames[k], self.T_w_c0[k])
        if finalize:
            writer.add_gcps(self.gcps)
            writer.finalize()


def folder_hashes(folder: Path) -> dict:
    """{relative path: sha256} of every file under ``folder``."""
    folder = Path(folder)
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_synth_motion_is_rigid_and_imu_offset():
    # The helpers other tests rely on: rotations orthonormal, IMU not at the body origin.
    s = Synth()
    R = s.T_w_i[:, :3, :3]
    assert np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-12)
    assert np.linalg.norm(s.rig.imu.T_b_i_array[:3, 3]) > 0.5
    assert abs(s.rig.baseline - 0.27) < 1e-12
