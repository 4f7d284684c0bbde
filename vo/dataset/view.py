"""The base of the reader-API views of an opened dataset (:class:`vo.dataset.frame_stride.FrameStride`,
:class:`vo.dataset.fisheye_view.RectifiedFisheyeView`): a view defines ``frame(k)`` (and whatever else it
changes); every other attribute is the viewed dataset's, and ``frames`` iterates the view's own ``frame``."""
from __future__ import annotations

from typing import Iterator, Optional

from rigs.records import StereoFrame


class DatasetView:
    """A view of ``dataset`` (``_ds``); subclasses define ``frame(k) -> StereoFrame`` and, where it differs,
    ``__len__``."""

    def __init__(self, dataset):
        self._ds = dataset

    def __getattr__(self, name):          # kind, name, path, frame_times_ns, imu, gcps, metadata, wheels, ...
        return getattr(self._ds, name)

    def __len__(self) -> int:
        return len(self._ds)

    def frames(self, start: int = 0, stop: Optional[int] = None, step: int = 1) -> Iterator[StereoFrame]:
        for k in range(*slice(start, stop, step).indices(len(self))):
            yield self.frame(k)
