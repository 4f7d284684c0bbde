"""Image sensor noise, the testbed's one noise model, and a reader-API dataset that re-noises on the fly.

The model: i.i.d. Gaussian grey-level noise of std ``sigma``, rounded and clipped to uint8 (a camera's
quantisation): ``clip(rint(img + sigma n), 0, 255)``. Two draws of it:

- :func:`add_quantized_noise`, the simulator camera's (:mod:`sim.sensors.camera`): as ``img`` holds whole
  grey levels, ``rint(img + sigma n) = img + rint(sigma n)``, so it draws the integer offset
  ``d = rint(sigma n)`` directly, with its exact probabilities ``P(d) = Phi((d + 1/2) / sigma) -
  Phi((d - 1/2) / sigma)`` (offsets beyond +-255 clip alike and are merged into +-255): one
  16-bit uniform index into a 65536-entry table holding ``floor(65536 P(d))`` entries of each ``d``; the
  few entries left over (the fractional parts) send a pixel to an exact float64 inverse-CDF draw of the
  residual masses. The index is drawn in two steps, its high byte for every pixel and its low byte only
  where needed: the high byte picks one of 256 buckets of 256 sorted entries, and a bucket whose entries
  all hold one offset (for sigma 1, 248 of 256) gives it through a 256-entry look-up table (``cv2.LUT``);
  only the pixels of the other buckets (about 3 %) draw a low byte and read the full table. As the two
  bytes of a uniform 16-bit index are independent uniform bytes, each pixel's offset has the table's
  distribution exactly, at one random byte per pixel (plus 3 %): the raw 64-bit words of the PCG64
  stream, eight bytes per word. The codes (``d + 128``) then go through one saturating
  ``cv2.addWeighted`` pass. The written pixels have the same distribution as the Gaussian sum, at a tenth
  of its cost (``vo-testbed bench generate --noise``; docs/simulator.md). Dataset version 0.4.0 (this
  draw's bytes differ from 0.3.0's, which drew all 16 bits of every pixel).
- :func:`add_image_noise`, the Monte-Carlo re-noising readers' (below): the Gaussian sum itself, in
  float64 (``dtype``). It is kept so that the Monte-Carlo runs keep their bytes: an estimator's discrete
  decisions make any change of draw act as a new noise draw (klt-pnp on campus-short, sigma 1: end
  positions 10-24 mm apart, as far as two seeds).

:class:`ImageNoiseDataset` is used by the Monte-Carlo runs (:class:`sim.app.nees.NoisyDataset`,
which adds IMU noise) and by the re-noising propagation (:mod:`vo.errorprop.renoise`). Frame ``k`` of
stream ``key`` draws from ``default_rng([*key, k, tag])`` alone, so frames may be read in any order
and give the same bytes.
"""
from __future__ import annotations

import functools
import math
import threading

import cv2
import numpy as np

from rigs.records import StereoFrame
from rigs.errors import RecordError

MC_TAG = 0xC0FFEE           # the Monte-Carlo runs' stream tag (sim.app.nees)
REAL_DRAW_TAG = 0xD2A3      # the noise draws of the real-recording benchmark (sim.app.bench_real)
TABLE_BITS = 16             # add_quantized_noise: a 16-bit table index per pixel (drawn bytewise)
MAX_OFFSET = 255            # offsets beyond +-255 grey levels clip alike (merged into +-255)
_ESCAPE = np.iinfo(np.int16).min
_SCRATCH = threading.local()   # add_quantized_noise's per-thread work arrays
_BIAS = 128                 # a bucket's offset d is stored as the byte d + 128 (0 marks a mixed bucket)


def add_quantized_noise(img: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``clip(img + rint(sigma n), 0, 255)`` with the integer offsets drawn directly (module docstring).

    ``img``: (H,W) or (H,W,3) uint8; returns a new uint8 array of the same shape. Draws, in order:
    ``img.size`` uniform bytes (:func:`_uniform_bytes`: the high bytes of the 16-bit table index), then
    as many bytes for the ``m`` pixels of mixed buckets (their low bytes, in pixel order), then
    ``rng.random(e)`` for the ``e`` of those whose entry is a residual one (for sigma 1, m is about 3 %
    of the pixels and e about 4e-5). ``sigma = 0`` returns an unchanged copy and draws nothing.
    """
    sigma = _check_sigma(sigma)
    _check_uint8(img)
    if sigma == 0:
        return img.copy()
    table, values, residual_cdf = _offset_table(sigma)
    codes, special = _entry_codes(sigma)
    src = np.ascontiguousarray(img).reshape(img.shape[0], -1)                # (H, W*C)
    high = _uniform_bytes(rng, img.size).reshape(src.shape)
    code, is_mixed, mask_words = _scratch(src.shape)
    cv2.LUT(high, _bucket_lut(sigma), dst=code)                              # d + 128, or 0: mixed bucket
    mixed = _zero_positions(code, is_mixed, mask_words)
    wide = None
    if mixed.size:
        index = np.left_shift(high.reshape(-1)[mixed], 8, dtype=np.uint16)
        index |= _uniform_bytes(rng, mixed.size)
        code.reshape(-1)[mixed] = np.take(codes, index)
        exact = np.flatnonzero(np.take(special, index))                     # residual or beyond +-127
        if exact.size:
            offsets = table[index[exact]]
            escaped = np.flatnonzero(offsets == _ESCAPE)
            if escaped.size:
                u = rng.random(escaped.size) * residual_cdf[-1]
                pick = np.minimum(np.searchsorted(residual_cdf, u, side="right"), len(values) - 1)
                offsets[escaped] = values[pick]
            code.reshape(-1)[mixed[exact]] = np.clip(offsets, -_BIAS, _BIAS - 1) + _BIAS
            wide = np.flatnonzero(np.abs(offsets) > _BIAS - 1)
            wide_at, wide_offsets = mixed[exact[wide]], offsets[wide]
    out = cv2.addWeighted(src, 1.0, code, 1.0, -float(_BIAS), dst=high, dtype=cv2.CV_8U)  # saturating, in place
    if wide is not None and wide.size:
        out.reshape(-1)[wide_at] = np.clip(src.reshape(-1)[wide_at] + wide_offsets, 0, 255)
    return out.reshape(img.shape)


def _zero_positions(code: np.ndarray, is_mixed: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Flat indices of the zero bytes of ``code`` (H, W*C); ``is_mixed`` (H, W*C) bool is a view of the
    head of ``flat``, whose tail (up to a multiple of 8) holds False: the mask's 8-byte words are scanned first
    and only the words with a zero byte are expanded (twice as fast as ``flatnonzero`` on the whole mask
    when about 3 % of the bytes are zero)."""
    np.equal(code, 0, out=is_mixed)
    words = flat.view(np.uint64)
    hit = np.flatnonzero(words != 0)
    z = np.flatnonzero(words[hit].view(bool))
    return hit[z >> 3] * 8 + (z & 7)


def _scratch(shape: tuple) -> tuple:
    """This thread's reused work arrays for an image of ``shape`` (H, W*C): bucket codes (uint8) and the
    mixed-bucket mask (bool) as a view of a flat array padded with False to a multiple of 8 bytes, and that array. Reusing
    them spares the page faults of fresh large allocations, which cost as much as the arithmetic; one set
    per thread, as frames are noised in worker threads concurrently."""
    arrays = getattr(_SCRATCH, "arrays", None)
    if arrays is None or arrays[0].shape != shape:
        n = shape[0] * shape[1]
        flat = np.zeros(-(-n // 8) * 8, bool)
        arrays = _SCRATCH.arrays = (np.empty(shape, np.uint8), flat[:n].reshape(shape), flat)
    return arrays


def _uniform_bytes(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n,) uint8 uniform bytes from ``rng``: with numpy's PCG64, the little-endian bytes of
    ``ceil(n / 8)`` raw 64-bit words (``random_raw``; the unused bytes of the last word are dropped), the
    cheapest uniform bits it gives; any other bit generator (some give 32-bit raw words) through
    ``rng.integers(0, 256, n, uint8)``."""
    bits = rng.bit_generator
    if type(bits) is not np.random.PCG64:
        return rng.integers(0, 256, size=n, dtype=np.uint8)
    return bits.random_raw(-(-n // 8)).astype("<u8", copy=False).view(np.uint8)[:n]


def offset_probabilities(sigma: float) -> tuple:
    """``(d, P(d))``: the offsets -255..255 and the probabilities of ``rint(sigma n) = d``, +-255 holding
    the tails (upper-tail complements, so small probabilities keep their relative precision)."""
    sigma = _check_sigma(sigma)
    d = np.arange(-MAX_OFFSET, MAX_OFFSET + 1)
    q = lambda x: 0.5 * math.erfc(x / math.sqrt(2.0))     # noqa: E731  upper tail of N(0, 1)
    half = [q((k - 0.5) / sigma) - (q((k + 0.5) / sigma) if k < MAX_OFFSET else 0.0)
            for k in range(1, MAX_OFFSET + 1)]
    p = np.array(half[::-1] + [math.erf(0.5 / (sigma * math.sqrt(2.0)))] + half)
    return d, p


@functools.lru_cache(maxsize=16)
def _offset_table(sigma: float) -> tuple:
    """``(table (65536,) int16, values (511,) int16, residual_cdf (511,) float64)`` for ``sigma > 0``."""
    d, p = offset_probabilities(sigma)
    n = 1 << TABLE_BITS
    counts = np.floor(p * n).astype(np.int64)
    table = np.full(n, _ESCAPE, np.int16)
    table[:counts.sum()] = np.repeat(d, counts)
    residual = np.clip(p * n - counts, 0.0, None)
    return table, d.astype(np.int16), np.cumsum(residual)


@functools.lru_cache(maxsize=16)
def _entry_codes(sigma: float) -> tuple:
    """``(codes (65536,) uint8, special (65536,) bool)``: each table entry's byte code ``d + 128`` and
    whether it needs the exact path (a residual entry, or ``|d| > 127``, which a byte code cannot hold)."""
    table = _offset_table(sigma)[0].astype(np.int32)
    special = (table == _ESCAPE) | (np.abs(table) > _BIAS - 1)
    return (np.clip(table, -_BIAS, _BIAS - 1) + _BIAS).astype(np.uint8), special


@functools.lru_cache(maxsize=16)
def _bucket_lut(sigma: float) -> np.ndarray:
    """(256,) uint8: for each high byte of the 16-bit uniform, ``d + 128`` where the table's 256 entries of
    that bucket all hold the one offset ``d`` (``|d| <= 127``), else 0 (several offsets or residual entries:
    the pixel reads the full table)."""
    buckets = _offset_table(sigma)[0].reshape(256, 256).astype(np.int32)
    pure = (buckets == buckets[:, :1]).all(axis=1) & (np.abs(buckets[:, 0]) < _BIAS)
    return np.where(pure, buckets[:, 0] + _BIAS, 0).astype(np.uint8)


def add_image_noise(img: np.ndarray, sigma: float, rng: np.random.Generator, dtype=np.float32) -> np.ndarray:
    """Add i.i.d. Gaussian noise of std ``sigma`` (grey levels) to a uint8 image, round, clip.

    ``img``: (H,W) or (H,W,3) uint8; returns a new uint8 array of the same shape. The draws are
    ``sigma * rng.standard_normal(img.shape)``, summed with the image in ``dtype`` (float32 or float64).
    ``sigma = 0`` returns an unchanged copy and draws nothing from ``rng``.
    """
    sigma = _check_sigma(sigma)
    _check_uint8(img)
    if dtype not in (np.float32, np.float64):
        raise RecordError(f"image noise dtype: {dtype!r}; must be numpy float32 or float64")
    if sigma == 0:
        return img.copy()
    noisy = img.astype(dtype) + rng.normal(0.0, sigma, size=img.shape).astype(dtype)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def _check_uint8(img) -> None:
    if not isinstance(img, np.ndarray) or img.dtype != np.uint8:
        raise RecordError(f"image noise: expected a uint8 image, got {getattr(img, 'dtype', type(img).__name__)}")


def _check_sigma(sigma) -> float:
    try:
        value = float(sigma)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value) or value < 0:
        raise RecordError(f"image noise sigma: {sigma!r}; must be a finite number >= 0")
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
