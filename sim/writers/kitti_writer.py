"""KITTI odometry writer: rectified grayscale stereo, ``calib.txt``, ``times.txt``, ``poses/NN.txt``.

Layout (the real KITTI odometry tree, plus our root files)::

    out_dir/
      INCOMPLETE (while writing)  metadata.yaml  gcps.csv (only when a check point was reached)
      sequences/00/image_0/000000.png  image_1/000000.png  calib.txt  times.txt  times_ns.txt
      poses/00.txt

``calib.txt``: P0..P3 of :func:`rigs.rectify.stereo_rectify` (P2 = P0, P3 = P1) and ``Tr``, the 3x4
``T_r0_b``: it maps points of our body frame ``b`` into the rectified left camera ``r0``
(``p_r0 = Tr @ [p_b; 1]``), in the place of real KITTI's velodyne-to-cam0 ``Tr``. ``times.txt``:
seconds since the first frame, ``%.6e`` as KITTI writes it; ``times_ns.txt`` (our extension)
holds the exact int64 frame times. ``poses/00.txt``: ``T_r0(0)_r0(k)``, the rectified left
camera ``r0`` at frame k in its own frame at frame 0, where ``T_w_r0 = T_w_c0 @ [R0_rect^T | 0]``.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from rigs.atomic_io import atomic_write_text
from rigs.calib_io import write_kitti_calib
from rigs.geometry import inv_T, make_T
from rigs.image import to_gray
from rigs.rectify import stereo_rectify
from rigs.trajectory import Trajectory
from rigs.trajfile import write_kitti
from sim.errors import SimError
from sim.stage_timer import NO_TIMER
from sim.writers.common import (CsvStream, PngOptions, commit_folder, config_hash, final_metadata, fmt_float,
                                prepare_folder, write_marker, write_png)

FRAMES_HEADER = "#timestamp [ns],index"
TRUTH_HEADER = "#timestamp [ns],T_w_c0 row-major 3x4 (12 numbers)"


def kitti_resume_state(out_dir, sequence: str = "00") -> int:
    """Frames fully written: a row in the frame log and both rectified PNGs."""
    out_dir = Path(out_dir)
    seq = out_dir / "sequences" / sequence
    log = out_dir / "kitti_frames.csv"
    if not log.exists():
        return 0
    n = 0
    for line in log.read_text().split("\n")[:-1]:
        if not line.strip() or line.startswith("#"):
            continue
        name = f"{int(line.split(',')[1]):06d}.png"
        if not ((seq / "image_0" / name).exists() and (seq / "image_1" / name).exists()):
            break
        n += 1
    return n


class KittiWriter:
    """Stream a stereo sequence as KITTI odometry (see module docstring).

    ``add_imu``/``add_groundtruth`` are accepted and ignored (KITTI odometry has no IMU); poses come
    from ``add_cam0_truth(t_ns, T_w_c0)`` at frame times.
    """

    def __init__(self, out_dir, rig, metadata: dict, sequence: str = "00", overwrite: bool = False,
                 png: PngOptions = PngOptions()):
        if not (len(sequence) == 2 and sequence.isdigit()):
            raise SimError(f"KittiWriter: sequence must be two digits like '00', got {sequence!r}")
        self.rig, self.metadata, self.sequence = rig, dict(metadata), sequence
        self.png = png
        self.out_dir, resuming = prepare_folder(out_dir, self.metadata, overwrite)
        self._hash = config_hash(self.metadata)
        self.seq_dir = self.out_dir / "sequences" / sequence
        for k in (0, 1):
            (self.seq_dir / f"image_{k}").mkdir(parents=True, exist_ok=True)
        self.rect = stereo_rectify(rig)
        self._maps = self.rect.maps()
        write_kitti_calib(self.seq_dir / "calib.txt", self.rect.P0, self.rect.P1, Tr=self.T_r0_b())
        self.resumed_frames = kitti_resume_state(self.out_dir, sequence) if resuming else 0
        self._frames = CsvStream(self.out_dir / "kitti_frames.csv", FRAMES_HEADER, resuming,
                                 keep_rows=self.resumed_frames)
        self._truth = CsvStream(self.out_dir / "kitti_cam0_truth.csv", TRUTH_HEADER, resuming)
        self._gcps: list = []
        self.finalized = False
        self.extra_metadata: dict = {}      # finalize() adds these keys to metadata.yaml

    def T_r0_b(self) -> np.ndarray:
        """(4,4) body -> rectified left camera: ``inv(T_b_c0 @ T_c0_r0)``, ``T_c0_r0 = [R0_rect^T | 0]``."""
        return inv_T(self.rig.cameras[0].T_b_c_array @ make_T(self.rect.R0_rect.T, np.zeros(3)))

    def add_frame(self, t_ns: int, images=None, depth=None, seg=None, files_written: bool = False) -> None:
        """Rectify and write one stereo epoch (images as for EurocWriter; depth/seg ignored).
        ``files_written``: :meth:`write_frame_files` wrote them already; only the log row is added."""
        t_ns = int(t_ns)
        if self._frames.resume_t is not None and t_ns <= self._frames.resume_t:
            return
        index = self._frames.rows
        if not files_written:
            self.write_frame_files(t_ns, images, index=index)
        self._frames.append(t_ns, [index])
        write_marker(self.out_dir, self._hash, f"frames={self._frames.rows}")

    def write_frame_files(self, t_ns: int, images, depth=None, seg=None, index: int | None = None,
                          timer=NO_TIMER) -> None:
        """The two rectified PNGs of frame number ``index`` (the files of :meth:`add_frame`, without its
        log row); safe from several threads at once."""
        if len(images) != 2:
            raise SimError(f"add_frame: expected 2 images (left, right), got {len(images)}")
        for k in (0, 1):
            with timer.stage("rectify"):
                rect = cv2.remap(to_gray(images[k]), *self._maps[k], interpolation=cv2.INTER_LINEAR)
            write_png(self.seq_dir / f"image_{k}" / f"{int(index):06d}.png", rect, rgb=False,
                      png=self.png, timer=timer)

    def add_cam0_truth(self, t_ns, T_w_c0) -> None:
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        T = np.asarray(T_w_c0, dtype=float).reshape(-1, 4, 4)
        for k in range(len(t)):
            self._truth.append(t[k], [fmt_float(x) for x in T[k, :3, :4].reshape(-1)])

    def add_imu(self, *args, **kwargs) -> None:
        """KITTI odometry has no IMU: ignored."""

    def add_groundtruth(self, *args, **kwargs) -> None:
        """IMU-frame ground truth is not part of KITTI: ignored (poses come from add_cam0_truth)."""

    def add_gcps(self, gcps) -> None:
        self._gcps.extend(gcps)

    def finalize(self, commit: bool = True) -> Path:
        """Write times.txt, times_ns.txt, poses/NN.txt, gcps.csv; with ``commit`` also :meth:`commit`
        (metadata.yaml, manifest, INCOMPLETE removed)."""
        from sim.writers.euroc_writer import write_gcps_csv
        self._frames.close()
        self._truth.close()
        t_frames = _read_log_times(self._frames.path)
        t0 = int(t_frames[0]) if len(t_frames) else 0
        atomic_write_text(self.seq_dir / "times.txt", "".join(f"{(t - t0) * 1e-9:.6e}\n" for t in t_frames))
        atomic_write_text(self.seq_dir / "times_ns.txt", "".join(f"{int(t)}\n" for t in t_frames))
        n_poses = self._write_poses(t_frames)
        gcp_note = write_gcps_csv(self.out_dir / "gcps.csv", self._gcps)
        self._frames.path.unlink()
        self._truth.path.unlink()
        meta = dict(self.metadata, **self.extra_metadata, format="kitti",
                    kitti={"sequence": self.sequence, "t0_ns": t0}, gcps=gcp_note)
        self.final_meta = final_metadata(meta, {"n_frames": len(t_frames), "n_poses": n_poses,
                                                "n_gcps": len(self._gcps)}, self.rig)
        if commit:
            self.commit()
        return self.out_dir

    def commit(self) -> None:
        """The last step: metadata.yaml (``status: complete``), manifest.json, then INCOMPLETE removed."""
        commit_folder(self.out_dir, self.final_meta)
        self.finalized = True

    def _write_poses(self, t_frames: np.ndarray) -> int:
        """poses/NN.txt with one pose per frame (all frames need a cam0 truth at the same time)."""
        rows = [ln.split(",") for ln in self._truth.path.read_text().splitlines()[1:] if ln.strip()]
        if not rows:
            return 0
        truth = {int(r[0]): np.vstack([np.array([float(x) for x in r[1:]]).reshape(3, 4), [0, 0, 0, 1]])
                 for r in rows}
        missing = [int(t) for t in t_frames if int(t) not in truth]
        if missing:
            raise SimError(f"{self.out_dir}: KITTI poses: no add_cam0_truth at frame time {missing[0]} ns "
                           f"({len(missing)} frames without a pose)")
        T_c0_r0 = make_T(self.rect.R0_rect.T, np.zeros(3))
        T_w_r0 = np.array([truth[int(t)] @ T_c0_r0 for t in t_frames])
        T_r00_r0 = np.einsum("ij,njk->nik", inv_T(T_w_r0[0]), T_w_r0)
        write_kitti(self.out_dir / "poses" / f"{self.sequence}.txt", Trajectory(t_frames, T_r00_r0, "c0_0", "c0"))
        return len(t_frames)


def _read_log_times(path: Path) -> np.ndarray:
    return np.array([int(ln.split(",")[0]) for ln in path.read_text().splitlines()
                     if ln.strip() and not ln.startswith("#")], dtype=np.int64)
