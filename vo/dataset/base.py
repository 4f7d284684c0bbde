"""The ``Dataset`` every estimator reads: stereo frames (lazy), IMU, ground truth, GCPs, rig.

Subclasses (:mod:`vo.dataset.euroc_reader`, :mod:`vo.dataset.kitti_reader`) fill in the frame list and the
loaders; images are read from disk only when a frame is asked for.
"""
from __future__ import annotations

import functools
from pathlib import Path
from typing import Iterator, Optional

import cv2
import numpy as np

from rigs.config_io import read_yaml_file
from rigs.errors import RigError
from rigs.records import Gcp, ImuSamples, StereoFrame, WheelSamples
from rigs.trajectory import Trajectory
from vo.errors import DatasetError


def load_gray(path: Path) -> np.ndarray:
    """PNG/any image -> (H,W) uint8 grayscale (colour: cv2 BGR2GRAY, the same weights the KITTI
    writer uses; 16-bit: top 8 bits)."""
    if not Path(path).is_file():
        raise DatasetError(f"{path}: image file not found")
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)   # not IMREAD_GRAYSCALE: libpng's own
    if img is None:                                       # conversion differs from cvtColor by 1 LSB
        raise DatasetError(f"{path}: cannot decode image")
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY if img.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    return img


def rig_or_error(fn, *args, **kwargs):
    """Call a ``rigs`` reader; a RigError becomes a DatasetError with the same one-line message."""
    try:
        return fn(*args, **kwargs)
    except RigError as exc:
        raise DatasetError(str(exc)) from None


class Dataset:
    """A stereo dataset on disk. Attributes: ``kind`` ("euroc"|"kitti"), ``path``, ``name``,
    ``rig`` (rigs.Rig), ``frame_times_ns`` (N,) int64, ``images_are_rectified``, ``warnings``."""

    kind: str = ""
    images_are_rectified: bool = False

    def __init__(self, path: Path, name: str, rig, frame_times_ns: np.ndarray, image_paths: list,
                 warnings: Optional[list] = None):
        self.path = Path(path)
        self.name = name
        self.rig = rig
        self.frame_times_ns = np.asarray(frame_times_ns, dtype=np.int64)
        self._image_paths = image_paths          # list of (left Path, right Path)
        self.warnings = list(warnings or [])
        _check_listed_images(image_paths)
        if image_paths:
            for k, p in enumerate(image_paths[0]):
                self._check_size(k, p, load_gray(p))

    def __len__(self) -> int:
        return int(self.frame_times_ns.shape[0])

    def __repr__(self) -> str:
        return f"<Dataset {self.kind} {self.name!r}: {len(self)} frames at {self.path}>"

    def frame(self, k: int) -> StereoFrame:
        """Stereo frame ``k`` (0 <= k < len): grayscale uint8 images read from disk now."""
        if not -len(self) <= k < len(self):
            raise DatasetError(f"{self.path}: frame index {k} out of range [0, {len(self)})")
        k = k % len(self)
        left, right = self._image_paths[k]
        for p in (left, right):
            if not p.is_file():
                raise DatasetError(f"{p}: image file not found (listed for frame {k}, missing from {p.parent}: "
                                   f"the image list and the folder disagree)")
        images = [self._check_size(c, p, load_gray(p)) for c, p in enumerate((left, right))]
        return StereoFrame(index=k, t_ns=int(self.frame_times_ns[k]), left=images[0], right=images[1])

    def _check_size(self, cam: int, path: Path, image: np.ndarray) -> np.ndarray:
        """``image`` of camera ``cam`` read from ``path``; one line naming the file and both sizes when it is
        not the size the rig gives that camera."""
        c = self.rig.cameras[cam]
        if image.shape[:2] != (c.height, c.width):
            raise DatasetError(f"{path}: image is {image.shape[1]}x{image.shape[0]} px, the rig's cam{cam} "
                               f"({c.name}) is {c.width}x{c.height} px; images and calibration disagree")
        return image

    def frames(self, start: int = 0, stop: Optional[int] = None, step: int = 1) -> Iterator[StereoFrame]:
        for k in range(*slice(start, stop, step).indices(len(self))):
            yield self.frame(k)

    # -- loaders overridden by subclasses -------------------------------------------------
    @functools.cached_property
    def imu(self) -> Optional[ImuSamples]:
        return None

    @functools.cached_property
    def groundtruth(self) -> Optional[Trajectory]:
        return None

    @functools.cached_property
    def gcps(self) -> list:
        return []

    def image_files(self, k: int) -> tuple:
        """``(left, right)`` paths of frame ``k`` as stored (exporters copy the file contents as they are)."""
        if not 0 <= k < len(self):
            raise DatasetError(f"{self.path}: frame index {k} out of range [0, {len(self)})")
        return self._image_paths[k]

    @functools.cached_property
    def metadata(self) -> dict:
        return {}

    @functools.cached_property
    def wheels(self) -> Optional[WheelSamples]:
        """Wheel-encoder ticks from ``wheels.csv`` in the dataset root; None when none were recorded."""
        from vo.dataset.wheels import read_wheels_csv
        return read_wheels_csv(Path(getattr(self, "root", self.path)) / "wheels.csv")

    def groundtruth_cam0(self) -> Trajectory:
        raise DatasetError(f"{self.path}: no ground truth in this dataset")

    def depth(self, k: int, cam: int = 0) -> np.ndarray:
        raise DatasetError(f"{self.path}: depth was not recorded in this dataset")


def _check_listed_images(image_paths: list) -> None:
    """Every listed image must exist: a truncated or edited ``data.csv`` (or deleted images) would
    otherwise surface as "image file not found" deep in a run. One line naming both sides."""
    missing = [p for pair in image_paths for p in pair if not Path(p).is_file()]
    if missing:
        folder = Path(missing[0]).parent
        raise DatasetError(f"{folder.parent / 'data.csv'} and {folder} disagree: {len(missing)} listed image(s) "
                           f"are not in the folder (first {Path(missing[0]).name!r}); a truncated or edited "
                           f"data.csv, or deleted images")


def read_gcps_csv(path: Path) -> list:
    """``#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z`` -> list of Gcp (empty if no file)."""
    from vo.dataset.csvio import data_rows
    import math
    path = Path(path)
    if not path.is_file():
        return []
    out = []
    for n, parts in data_rows(path, "gcps", 8):
        try:
            t_ns, vals = int(parts[1]), [float(x) for x in parts[2:]]
        except ValueError:
            raise DatasetError(f"{path}: line {n}: expected name,t_ns and 6 numbers, got {','.join(parts)[:60]!r}") from None
        if not all(math.isfinite(v) for v in vals):
            raise DatasetError(f"{path}: line {n}: NaN or inf in coordinates")
        out.append(Gcp(parts[0], t_ns, np.array(vals[:3]), np.array(vals[3:])))
    return out


def read_metadata(path: Path) -> dict:
    """``metadata.yaml`` -> dict ({} when absent); malformed YAML -> DatasetError naming it."""
    path = Path(path)
    if not path.is_file():
        return {}
    d = rig_or_error(read_yaml_file, path)
    if not isinstance(d, dict):
        raise DatasetError(f"{path}: expected a mapping at the top level, got {type(d).__name__}")
    return d
