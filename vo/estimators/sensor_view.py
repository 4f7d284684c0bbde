"""The sensor data of a dataset, and nothing else, in a throw-away folder for an external program.

An external estimator (``cmd:...``) must not see the answer: it gets a temporary folder with the
same layout holding only images, IMU, wheel ticks and calibration. Left out: ground truth
(``state_groundtruth_estimate0/``, ``groundtruth_tum.txt``, KITTI ``poses/``), depth, segmentation,
``gcps.csv``, ``metadata.yaml`` (it records the route), the sensor-effect truth (``rig_true.yaml``, the
calibration the images were rendered with when the written one is perturbed; ``sensor_effects.yaml``;
``frame_effects.csv``), the Kalibr ``camchain-imucam.yaml`` (its ``timeshift_cam_imu`` is the true
IMU clock offset; Kalibr's ``imu.yaml`` is shown) and plots. The view is an allow-list (``EUROC_*``, ``KITTI_*`` below): a file not
listed there is never shown. Files are hard links into the
dataset when the file system allows it (no copy of the images), copies otherwise; the folders of
the view are read-only. A hard-linked file shares its bytes with the dataset, so after the run
:meth:`SensorView.check_untouched` compares the size and modification time of every linked file
with those before the run and raises when the program wrote to one.
"""
from __future__ import annotations

import os
import shutil
import stat
import tempfile
from pathlib import Path

from vo.errors import EstimatorError

EUROC_ROOT_FILES = ("rig.yaml", "wheels.csv")
EUROC_MAV0_FILES = ("camchain.yaml", "imu.yaml", "body.yaml", "imu0/data.csv", "imu0/sensor.yaml",
                    "cam0/data.csv", "cam0/sensor.yaml", "cam1/data.csv", "cam1/sensor.yaml")
EUROC_MAV0_DIRS = ("cam0/data", "cam1/data")
KITTI_SEQ_FILES = ("calib.txt", "times.txt", "times_ns.txt")
KITTI_SEQ_DIRS = ("image_0", "image_1", "image_2", "image_3")


class SensorView:
    """``with SensorView(dataset) as folder:`` -> the view's root (a :class:`pathlib.Path`).

    ``dataset`` is an opened :class:`vo.dataset.base.Dataset` (EuRoC or KITTI, ours or real)."""

    def __init__(self, dataset):
        self.dataset = dataset
        self.root: Path | None = None
        self._linked: dict = {}           # source path -> (size, mtime_ns) before the run

    def __enter__(self) -> Path:
        self.root = Path(tempfile.mkdtemp(prefix="vo_sensors_"))
        try:
            for src, rel in self._entries():
                self._place(src, self.root / rel)
            _set_dirs_writable(self.root, False)
        except BaseException:
            self._remove()
            raise
        return self.root

    def __exit__(self, *exc) -> None:
        self._remove()

    def check_untouched(self, who: str) -> None:
        """Raise EstimatorError when ``who`` changed a dataset file through its hard link."""
        for src, before in self._linked.items():
            st = src.stat()
            if (st.st_size, st.st_mtime_ns) != before:
                raise EstimatorError(f"{who}: wrote to the dataset file {src} (hard-linked into its input "
                                     f"folder); programs must treat their input as read-only")

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

    def _place(self, src: Path, dst: Path) -> None:
        dst.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.link(src, dst)
        except OSError:                    # another file system, or links not allowed: copy
            shutil.copyfile(src, dst)
            os.chmod(dst, stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH)
            return
        st = src.stat()
        self._linked[src] = (st.st_size, st.st_mtime_ns)

    def _remove(self) -> None:
        if self.root is not None and self.root.exists():
            _set_dirs_writable(self.root, True)
            shutil.rmtree(self.root, ignore_errors=True)


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
