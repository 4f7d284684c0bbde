"""The sensor side of an opened dataset, for in-process estimators: frames, IMU, wheel ticks and the rig.

``Estimator.set_dataset`` receives a :class:`SensorDataset` unless the estimator declares that it reads ground
truth (``Estimator.is_oracle``: ``vins-oracle``, ``--opt init=truth``). It has no ground truth, depth,
segmentation, GCPs, metadata, and no path to the folder (from which truth could be read). This stops the
accidental use of truth by a plug-in; it is no barrier to a plug-in that goes looking (it runs in our process):
run untrusted code as a ``cmd:`` program, under namespace isolation (:mod:`vo.estimators.isolation`).
"""
from __future__ import annotations

from typing import Iterator, Optional

import numpy as np

from rigs.records import ImuSamples, StereoFrame, WheelSamples


class SensorDataset:
    """Read-only sensor view of ``dataset`` (a :class:`vo.dataset.base.Dataset`): ``kind``, ``name``, ``rig``,
    ``frame_times_ns`` (N,) int64, ``images_are_rectified``, ``len``, ``frame(k)``, ``frames(...)``, ``imu``,
    ``wheels``."""

    def __init__(self, dataset):
        self._ds = dataset
        self.kind = getattr(dataset, "kind", "")
        self.name = getattr(dataset, "name", "")
        self.rig = dataset.rig
        self.images_are_rectified = bool(getattr(dataset, "images_are_rectified", False))

    @property
    def frame_times_ns(self) -> np.ndarray:
        """(N,) int64 frame times (a copy)."""
        return np.array(self._ds.frame_times_ns, dtype=np.int64)

    def __len__(self) -> int:
        return len(self._ds)

    def __repr__(self) -> str:
        return f"<SensorDataset {self.kind} {self.name!r}: {len(self)} frames>"

    def frame(self, k: int) -> StereoFrame:
        return self._ds.frame(k)

    def frames(self, start: int = 0, stop: Optional[int] = None, step: int = 1) -> Iterator[StereoFrame]:
        return self._ds.frames(start, stop, step)

    @property
    def imu(self) -> Optional[ImuSamples]:
        return getattr(self._ds, "imu", None)

    @property
    def wheels(self) -> Optional[WheelSamples]:
        return getattr(self._ds, "wheels", None)
