"""Every ``step``-th frame of a recording: the same drive at 1/``step`` of its frame rate.

A camera ``step`` times slower, or a vehicle ``step`` times faster at the same frame rate, sees ``step`` times
the motion between frames: larger optical flow, more of it beyond a KLT pyramid's reach, fewer tracks that
survive from one frame to the next. ``vo-testbed bench real --stride N`` runs the estimators on this view of
a real recording (and of ours: the same view, so the simulator's prediction and the real figure are made
alike).

Frame ``k`` of the view is frame ``k * step`` of the recording, with that frame's timestamp; its ``index`` is
``k``. ``frame_times_ns`` (M,) int64, M = ceil(N / step). The IMU, the ground truth (matched to the poses by
time), the GCPs, the rig and the rest are the recording's own.
"""
from __future__ import annotations

import numpy as np

from rigs.records import StereoFrame
from vo.dataset.view import DatasetView
from vo.errors import DatasetError


def valid_step(step) -> bool:
    """Whether ``step`` is a frame stride: an integer (not a bool) >= 1."""
    return not isinstance(step, bool) and isinstance(step, (int, np.integer)) and step >= 1


class FrameStride(DatasetView):
    """Reader-API view of ``base`` (an opened dataset) holding its frames ``0, step, 2 step, ...``
    (``step`` an integer >= 1; 1 is the recording itself). Index-taking reads (``frame``, ``image_files``,
    ``depth``, ``segmentation``) map view index ``k`` to ``k * step``; everything else is ``base``'s."""

    def __init__(self, base, step: int):
        if not valid_step(step):
            raise DatasetError(f"{getattr(base, 'path', base)}: frame stride {step!r}; must be an integer >= 1")
        super().__init__(base)
        self.step = int(step)
        self.frame_times_ns = np.asarray(base.frame_times_ns, np.int64)[::self.step].copy()

    def __len__(self) -> int:
        return len(self.frame_times_ns)

    def __repr__(self) -> str:
        return f"<FrameStride every {self.step} of {self._ds!r}: {len(self)} frames>"

    def _source(self, k: int) -> int:
        """The recording's index of view frame ``k`` (negative ``k`` counts from the end)."""
        if not -len(self) <= k < len(self):
            raise DatasetError(f"{self._ds.path}: frame index {k} out of range [0, {len(self)}) "
                               f"(stride {self.step})")
        return (k % len(self)) * self.step

    def frame(self, k: int) -> StereoFrame:
        f = self._ds.frame(self._source(k))
        return StereoFrame(index=k % len(self), t_ns=f.t_ns, left=f.left, right=f.right)

    def image_files(self, k: int) -> tuple:
        return self._ds.image_files(self._source(k))

    def depth(self, k: int, cam: int = 0) -> np.ndarray:
        return self._ds.depth(self._source(k), cam)

    def segmentation(self, k: int, cam: int = 0) -> tuple:
        return self._ds.segmentation(self._source(k), cam)
