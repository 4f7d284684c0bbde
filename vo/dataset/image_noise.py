"""A reader-API dataset whose stereo images get seeded i.i.d. Gaussian grey-level noise on the fly.

Used by the Monte-Carlo runs (:class:`sim.app.consistency.NoisyDataset`, which adds IMU noise) and by the
re-noising propagation (:mod:`vo.errorprop.renoise`). Frame ``k`` of stream ``key`` draws from
``default_rng([*key, k, tag])`` alone, so frames may be read in any order and give the same bytes;
the noisy image is ``clip(rint(img + sigma n), 0, 255)`` as uint8, the rounding included (as a
camera's quantisation would be).
"""
from __future__ import annotations

import numpy as np

from vo.dataset.types import StereoFrame
from vo.errors import VoError

MC_TAG = 0xC0FFEE           # the Monte-Carlo runs' stream tag (sim.app.consistency)


class ImageNoiseDataset:
    """Wraps ``base`` (reader API); ``sigma`` grey levels (0: images unchanged), ``key`` int or tuple of
    ints naming the random stream, ``tag`` an int that separates uses of the same key. Delegates the rest."""

    def __init__(self, base, sigma: float, key, tag: int = MC_TAG):
        sigma = float(sigma)
        if not np.isfinite(sigma) or sigma < 0:
            raise VoError(f"image noise sigma: {sigma!r}; must be a finite number >= 0")
        self._base, self._sigma, self._tag = base, sigma, int(tag)
        self._key = tuple(int(k) for k in np.atleast_1d(key))

    def __getattr__(self, name):
        return getattr(self._base, name)

    def __len__(self):
        return len(self._base)

    def _noisy(self, frame: StereoFrame) -> StereoFrame:
        if self._sigma <= 0:
            return frame
        rng = np.random.default_rng([*self._key, frame.index, self._tag])
        imgs = [np.clip(np.rint(im.astype(np.float64) + self._sigma * rng.standard_normal(im.shape)), 0, 255)
                .astype(np.uint8) for im in (frame.left, frame.right)]
        return StereoFrame(frame.index, frame.t_ns, imgs[0], imgs[1])

    def frame(self, k):
        return self._noisy(self._base.frame(k))

    def frames(self, start=0, stop=None, step=1):
        for f in self._base.frames(start, stop, step):
            yield self._noisy(f)
