"""KITTI odometry sequences (``sequences/NN``): ours and real.

The rig comes from ``calib.txt`` (rectified pinhole pair, body = rectified left camera ``c0``);
the image size from the first left image; the rate from the median frame interval.
Ground truth ``T_c0_0_c0`` from ``poses/NN.txt`` two levels up (the real KITTI tree, and ours).
Frame times: our exact ``times_ns.txt`` when present (plus nothing else), otherwise
``times.txt`` seconds rounded to ns, offset by ``metadata.kitti.t0_ns`` when known.
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from rigs.calib_io import read_kitti_calib
from rigs.trajectory import Trajectory
from rigs.trajfile import read_kitti
from vo.dataset.base import Dataset, read_gcps_csv, read_metadata, rig_or_error
from vo.dataset.csvio import read_column
from vo.errors import DatasetError


def kitti_times_ns(seq: Path, t0_ns: int) -> np.ndarray:
    exact = seq / "times_ns.txt"
    if exact.is_file():
        return read_column(exact, "frame times (ns)", integer=True)
    t = np.round(read_column(seq / "times.txt", "frame times", integer=False) * 1e9).astype(np.int64) + t0_ns
    return t


def pair_images(seq: Path, n_times: int) -> tuple[list, list]:
    """Indices ``0 .. n_times-1``, each with both ``image_0/k`` and ``image_1/k`` -> (indices, warnings).

    As for EuRoC, a dataset whose files disagree is refused (one line naming the file): an image listed
    by ``times.txt`` but missing from ``image_0``/``image_1``, or more images than times (a truncated
    ``times.txt``)."""
    names = {}
    for k in (0, 1):
        folder = seq / f"image_{k}"
        if not folder.is_dir():
            raise DatasetError(f"{folder}: image folder not found")
        names[k] = {p.name for p in folder.iterdir() if p.suffix == ".png"}
    times = seq / "times.txt"
    for k in (0, 1):
        missing = [j for j in range(n_times) if f"{j:06d}.png" not in names[k]]
        if missing:
            raise DatasetError(f"{seq / f'image_{k}' / f'{missing[0]:06d}.png'}: image file not found "
                               f"({len(missing)} of the {n_times} frames in {times.name} have no image_{k} file)")
        if len(names[k]) > n_times:
            raise DatasetError(f"{times}: {n_times} frame times for {len(names[k])} images in image_{k}; "
                               f"a truncated {times.name} (or extra images)")
    return list(range(n_times)), []


class KittiDataset(Dataset):
    kind = "kitti"
    images_are_rectified = True

    def __init__(self, seq: Path, root: Path, ours: bool):
        import cv2
        self.seq, self.root, self.ours = Path(seq), Path(root), ours
        t_all = kitti_times_ns(self.seq, int(self.metadata.get("kitti", {}).get("t0_ns", 0)))
        if len(t_all) > 1 and np.any(np.diff(t_all) <= 0):
            raise DatasetError(f"{self.seq / 'times.txt'}: frame times must increase")
        keep, warnings = pair_images(self.seq, len(t_all))
        if not keep:
            raise DatasetError(f"{self.seq}: no stereo image pairs (image_0/000000.png ...)")
        self._indices = keep
        paths = [(self.seq / "image_0" / f"{k:06d}.png", self.seq / "image_1" / f"{k:06d}.png") for k in keep]
        first = cv2.imread(str(paths[0][0]), cv2.IMREAD_GRAYSCALE)
        if first is None:
            raise DatasetError(f"{paths[0][0]}: cannot decode image")
        dt = np.median(np.diff(t_all)) * 1e-9 if len(t_all) > 1 else 0.1
        rate = round(1.0 / dt, 6) if dt > 0 else 10.0
        name = str(self.metadata.get("name", f"kitti-{self.seq.name}"))
        rig = rig_or_error(read_kitti_calib, self.seq / "calib.txt", rate_hz=rate, width=first.shape[1],
                           height=first.shape[0], name=name)
        super().__init__(self.seq, name, rig, t_all[keep], paths, warnings)

    @functools.cached_property
    def metadata(self) -> dict:
        return read_metadata(self.root / "metadata.yaml") if self.ours else {}

    @functools.cached_property
    def groundtruth(self):
        """``T_c0_0_c0`` (ref "c0_0", frame "c0") at frame times, or None without poses/NN.txt."""
        path = self.seq.parent.parent / "poses" / f"{self.seq.name}.txt"
        if not path.is_file():
            return None
        all_poses = read_kitti(path)
        n_times = max(self._indices) + 1
        if len(all_poses) < n_times:
            raise DatasetError(f"{path}: {len(all_poses)} poses for {n_times} frames in {self.seq / 'times.txt'}")
        return Trajectory(self.frame_times_ns, all_poses.T[self._indices], "c0_0", "c0")

    def groundtruth_cam0(self) -> Trajectory:
        """For KITTI the world is the first rectified left camera: same as :attr:`groundtruth`."""
        gt = self.groundtruth
        if gt is None:
            raise DatasetError(f"{self.seq.parent.parent / 'poses'}: no poses/{self.seq.name}.txt; no ground truth")
        return gt

    @functools.cached_property
    def gcps(self) -> list:
        return read_gcps_csv(self.root / "gcps.csv") if self.ours else []
