"""Streaming Python API: ``for frame in sim.stream(config): ...`` yields the stereo frames, the IMU
samples up to each frame and the ground truth in memory, without writing a dataset (for training loops).

The data are those :func:`sim.generate.generate` writes for the same configuration (same random
streams, same stamps): a frame's images equal the dataset's PNGs, its IMU samples the rows of
``mav0/imu0/data.csv`` (stamped ``t_imu = t_cam + td``), its truth the rows of
``mav0/state_groundtruth_estimate0/data.csv`` and ``groundtruth_tum.txt`` (``tests/test_stream.py``).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from sim.errors import SimError
from sim.generate import imu_streams, resolve, truth_records
from sim.generate_config import GenerateConfig
from sim.rng import indexed_stream, stream as rng_stream
from sim.sensors.calib_error import perturb_rig
from sim.sensors.camera import FrameExposer, StereoCamera, add_noise
from sim.sensors.effects_truth import time_offset_ns


@dataclass(frozen=True)
class StreamFrame:
    """One stereo epoch.

    ``k`` frame index; ``t_ns`` its stamp (as the dataset's ``data.csv``); ``images`` [left, right] (H,W) uint8
    (or (H,W,3) with ``rgb``); ``depth`` / ``seg`` as the renderer gives them (None unless configured);
    ``imu_t_ns`` (M,), ``gyro`` / ``accel`` (M,3) the IMU samples stamped in ``(t_ns of frame k-1, t_ns]``
    (frame 0: every sample up to it); ``T_w_b`` / ``T_w_c0`` (4,4) the true body and left-camera poses at
    the frame; ``truth_T_w_i`` (M,4,4), ``truth_v_w`` (M,3), ``truth_b_g`` / ``truth_b_a`` (M,3) the IMU
    frame's true state at the true times of those IMU samples (``truth_t_ns`` (M,))."""

    k: int
    t_ns: int
    images: list
    depth: object
    seg: object
    imu_t_ns: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    T_w_b: np.ndarray
    T_w_c0: np.ndarray
    truth_t_ns: np.ndarray
    truth_T_w_i: np.ndarray
    truth_v_w: np.ndarray
    truth_b_g: np.ndarray
    truth_b_a: np.ndarray


class FrameStream:
    """Iterable of :class:`StreamFrame` for ``config``; ``rig`` is the calibration a dataset would carry
    (perturbed when ``calib_error`` is set; ``rig_true`` the one the images are rendered with). The
    scene, trajectory and IMU are computed on construction; frames are rendered one at a time while
    iterating (one off-screen GL context, released when the iteration ends or the generator is closed)."""

    def __init__(self, config: GenerateConfig):
        if not config.images:
            raise SimError("images: false: sim.stream yields frames; use generate for IMU and ground truth only")
        self.config = config
        self.setup = resolve(config)
        noisy, self.biases = imu_streams(self.setup)
        self.imu = dataclasses.replace(noisy, t_ns=noisy.t_ns + time_offset_ns(config))
        self.truth = truth_records(self.setup, self.biases)
        self.rig_true = self.setup.rig
        self.rig, _ = perturb_rig(self.setup.rig, config.calib_error, rng_stream(config.seed, "calib_error"))

    def __len__(self) -> int:
        return int(len(self.setup.frame_t_ns))

    def __iter__(self) -> Iterator[StreamFrame]:
        s, c, tr = self.setup, self.config, self.truth
        pose_at = lambda t_ns: s.trajectory.states(t_ns).T_w_b  # noqa: E731
        imu_t, prev = self.imu.t_ns, None
        with StereoCamera(s.scene, s.rig, vehicle=c.vehicle, depth=c.depth, segmentation=c.segmentation,
                          supersample=s.supersample, rgb=c.rgb) as camera:
            exposer = FrameExposer(camera, s.rig, c.camera, 1.0 / s.rig.camera_rate_hz, c.seed, s.image_noise,
                                   noisy=not c.ideal) if c.camera.image_effects else None
            for k in range(len(s.frame_t_ns)):
                t_k = int(s.frame_t_ns[k])
                if exposer is None:
                    images, depth, seg = camera.measure(tr["T_w_b_frames"][k], s.scene.actor_states(t_k))
                    images = add_noise(images, s.image_noise, indexed_stream(c.seed, "image_noise", k))
                else:
                    images, depth, seg, _ = exposer.expose(k, t_k, pose_at, s.scene.actor_states)
                stamp = int(s.frame_stamp_ns[k])
                sel = (imu_t <= stamp) if prev is None else (imu_t > prev) & (imu_t <= stamp)
                prev = stamp
                yield StreamFrame(k, stamp, images, depth, seg, imu_t[sel], self.imu.gyro[sel], self.imu.accel[sel],
                                  tr["T_w_b_frames"][k], tr["T_w_c0"][k], s.imu_t_ns[sel], tr["T_w_i"][sel],
                                  tr["v_w_i"][sel], self.biases.b_g[sel], self.biases.b_a[sel])


def stream(config: GenerateConfig | None = None) -> FrameStream:
    """``for f in sim.stream(cfg): f.images, f.gyro, f.T_w_c0 ...`` (see :class:`StreamFrame`); default
    configuration when ``config`` is None."""
    return FrameStream(config if config is not None else GenerateConfig())
