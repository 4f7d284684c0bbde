"""The sensor data of a dataset, and nothing else, in a throw-away folder for an external program.

An external estimator (``cmd:...``) must not see the answer: it gets a temporary folder with the
same layout holding only images, IMU, wheel ticks and calibration. Left out: ground truth
(``state_groundtruth_estimate0/``, ``groundtruth_tum.txt``, KITTI ``poses/``), depth, segmentation,
``gcps.csv``, ``metadata.yaml`` (it records the route), the sensor-effect truth (``rig_true.yaml``, the
calibration the images were rendered with when the written one is perturbed; ``sensor_effects.yaml``;
``frame_effects.csv``), the Kalibr ``camchain-imucam.yaml`` (its ``timeshift_cam_imu`` is the true
IMU clock offset; Kalibr's ``imu.yaml`` is shown) and plots. The view is an allow-list (``EUROC_*``, ``KITTI_*`` below): a file not
listed there is never shown. Every file is a read-only copy (never a hard link: a program running as root
could write through one into the dataset), so the dataset and the scenario cache cannot be changed through
the view. The SHA-256 of every file is taken while copying; :meth:`SensorView.check_untouched` hashes the
view again after the run and raises, naming the file, when one was changed, removed or added.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import stat
import tempfile
from pathlib import Path

from rigs.atomic_io import sha256_file
from vo.errors import EstimatorError

EUROC_ROOT_FILES = ("rig.yaml", "wheels.csv")
EUROC_MAV0_FILES = ("camchain.yaml", "imu.yaml", "body.yaml", "imu0/data.csv", "imu0/sensor.yaml",
                    "cam0/data.csv", "cam0/sensor.yaml", "cam1/data.csv", "cam1/sensor.yaml")
EUROC_MAV0_DIRS = ("cam0/data", "cam1/data")
KITTI_SEQ_FILES = ("calib.txt", "times.txt", "times_ns.txt")
KITTI_SEQ_DIRS = ("image_0", "image_1", "image_2", "image_3")


class SensorView:
    """``with SensorView(dataset, root) as folder:`` -> the view's root (a :class:`pathlib.Path`), ``root`` when
    given (a folder that must not exist yet), else a new temporary folder; removed on exit.

    ``dataset`` is an opened :class:`vo.dataset.base.Dataset` (EuRoC or KITTI, ours or real)."""

    def __init__(self, dataset, root=None):
        self.dataset = dataset
        self._given = Path(root) if root is not None else None
        self.root: Path | None = None
        self.digests: dict = {}            # relative path -> SHA-256 of the copy as written

    def __enter__(self) -> Path:
        if self._given is not None:
            self._given.mkdir()
            self.root = self._given
        else:
            self.root = Path(tempfile.mkdtemp(prefix="vo_sensors_"))
        try:
            for src, rel in self._entries():
                self.digests[str(rel)] = _copy_read_only(src, self.root / rel)
            _set_dirs_writable(self.root, False)
        except BaseException:
            self._remove()
            raise
        return self.root

    def __exit__(self, *exc) -> None:
        self._remove()

    def check_untouched(self, who: str) -> None:
        """Raise EstimatorError naming the first file of the view that ``who`` changed, removed or added."""
        now = {str(p.relative_to(self.root)) for p in self.root.rglob("*") if not p.is_dir()}
        for rel, digest in self.digests.items():
            if rel not in now:
                raise EstimatorError(f"{who}: removed the sensor file {rel} from its input folder; programs must "
                                     f"treat their input as read-only (the dataset itself is untouched)")
            if sha256_file(self.root / rel) != digest:
                raise EstimatorError(f"{who}: changed the sensor file {rel} in its input folder (SHA-256 differs "
                                     f"after the run); programs must treat their input as read-only (the dataset "
                                     f"itself is untouched)")
        added = sorted(now - set(self.digests))
        if added:
            raise EstimatorError(f"{who}: added {added[0]} to its input folder; programs must treat their input "
                                 f"as read-only (write only to {{out}})")

    def _entries(self):
        ds = self.dataset
        if ds.kind == "euroc":
            yield from _files(ds.root, "", EUROC_ROOT_FILES)
            yield from _files(ds.mav0, "mav0", EUROC_MAV0_FILES)
            yield from _dirs(ds.mav0, "mav0", EUROC_MAV0_DIRS)
        elif ds.kind == "kitti":
            rel = Path("sequences") / ds.seq.name
            yield from _files(ds.root, "", ("rig.yaml",))
            yield from _files(ds.seq, rel, KITTI_SEQ_FILES)
            yield from _dirs(ds.seq, rel, KITTI_SEQ_DIRS)
        else:
            raise EstimatorError(f"{ds.path}: no sensor view for a {ds.kind!r} dataset")

    def _remove(self) -> None:
        if self.root is not None and self.root.exists():
            _set_dirs_writable(self.root, True)
            shutil.rmtree(self.root, ignore_errors=True)


def _copy_read_only(src: Path, dst: Path) -> str:
    """Copy ``src`` to ``dst`` (mode 0444) -> the SHA-256 of the bytes written."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    h = hashlib.sha256()
    with open(src, "rb") as fi, open(dst, "wb") as fo:
        for block in iter(lambda: fi.read(1 << 20), b""):
            h.update(block)
            fo.write(block)
    os.chmod(dst, stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH)
    return h.hexdigest()



def _files(base: Path, rel, names):
    for name in names:
        if (Path(base) / name).is_file():
            yield Path(base) / name, Path(rel) / name


def _dirs(base: Path, rel, names):
    for name in names:
        folder = Path(base) / name
        if folder.is_dir():
            for f in sorted(folder.iterdir()):
                if f.is_file():
                    yield f, Path(rel) / name / f.name


def _set_dirs_writable(root: Path, writable: bool) -> None:
    mode = 0o755 if writable else 0o555
    for folder, _, _ in os.walk(root):
        os.chmod(folder, mode)
