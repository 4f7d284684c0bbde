"""Image sensor noise, the testbed's one implementation, and a reader-API dataset that re-noises on the fly.

:func:`add_image_noise` is the camera's noise step: i.i.d. Gaussian grey-level noise of std ``sigma``,
rounded and clipped to uint8 (a camera's quantisation): ``clip(rint(img + sigma n), 0, 255)``. The
simulator's camera (:mod:`sim.sensors.camera`) writes datasets with it (sum in float32) and the
re-noising readers below use it (sum in float64). The two sums round differently in about 5e-6 of
the pixels (one grey level); the precisions are kept so that generated datasets and the Monte-Carlo
runs keep their bytes: an estimator's discrete decisions make that one-grey-level difference act as a
new noise draw (klt-pnp on campus-short, sigma 1: end positions 10-24 mm apart, as far as two seeds).

:class:`ImageNoiseDataset` is used by the Monte-Carlo runs (:class:`sim.app.consistency.NoisyDataset`,
which adds IMU noise) and by the re-noising propagation (:mod:`vo.errorprop.renoise`). Frame ``k`` of
stream ``key`` draws from ``default_rng([*key, k, tag])`` alone, so frames may be read in any order
and give the same bytes.
"""
from __future__ import annotations

import numpy as np

from vo.dataset.types import StereoFrame
from vo.errors import VoError

MC_TAG = 0xC0FFEE           # the Monte-Carlo runs' stream tag (sim.app.consistency)


def add_image_noise(img: np.ndarray, sigma: float, rng: np.random.Generator, dtype=np.float32) -> np.ndarray:
    """Add i.i.d. Gaussian noise of std ``sigma`` (grey levels) to a uint8 image, round, clip.

    ``img``: (H,W) or (H,W,3) uint8; returns a new uint8 array of the same shape. The draws are
    ``sigma * rng.standard_normal(img.shape)``, summed with the image in ``dtype`` (float32 or float64).
    ``sigma = 0`` returns an unchanged copy and draws nothing from ``rng``.
    """
    sigma = _check_sigma(sigma)
    if not isinstance(img, np.ndarray) or img.dtype != np.uint8:
        raise VoError(f"image noise: expected a uint8 image, got {getattr(img, 'dtype', type(img).__name__)}")
    if dtype not in (np.float32, np.float64):
        raise VoError(f"image noise dtype: {dtype!r}; must be numpy float32 or float64")
    if sigma == 0:
        return img.copy()
    noisy = img.astype(dtype) + rng.normal(0.0, sigma, size=img.shape).astype(dtype)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def _check_sigma(sigma) -> float:
    try:
        value = float(sigma)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value) or value < 0:
        raise VoError(f"image noise sigma: {sigma!r}; must be a finite number >= 0")
    return value


class ImageNoiseDataset:
    """Wraps ``base`` (reader API); ``sigma`` grey levels (0: images unchanged), ``key`` int or tuple of
    ints naming the random stream, ``tag`` an int that separates uses of the same key. Delegates the rest."""

    def __init__(self, base, sigma: float, key, tag: int = MC_TAG):
        sigma = _check_sigma(sigma)
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
        imgs = [add_image_noise(im, self._sigma, rng, np.float64) for im in (frame.left, frame.right)]
        return StereoFrame(frame.index, frame.t_ns, imgs[0], imgs[1])

    def frame(self, k):
        return self._noisy(self._base.frame(k))

    def frames(self, start=0, stop=None, step=1):
        for f in self._base.frames(start, stop, step):
            yield self._noisy(f)
