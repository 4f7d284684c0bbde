"""Image noise level from one image: Immerkaer's estimator on the image's flattest pixels.

J. Immerkaer, "Fast noise variance estimation", CVIU 64(2), 1996: the image is filtered with the
difference of two 3x3 Laplacians, ``N = [[1,-2,1],[-2,4,-2],[1,-2,1]]``, which cancels structure up
to second order; i.i.d. Gaussian noise of std ``sigma`` gives an output of std ``6 sigma`` and
``sigma = sqrt(pi/2) mean|I * N| / 6`` (eq. 4). On textured renderings the texture that is not
locally quadratic passes the filter: on campus frames with sigma = 1 (+ rounding: 1.04 true) the
whole-image estimate is 1.38. So, as Tai & Yang (ISCCSP 2008) exclude edge pixels found by a Sobel
detector, the mean is taken over the ``flat_fraction`` of pixels with the smallest Sobel magnitude
(our choice of 0.2, measured: 1.07-1.08 for 1.04 on three campus frames; 0.59 for 0.58 at sigma 0.5;
2.05 for 2.02 at sigma 2; ``tests/test_frontend_lk_noise.py``). Rounding to integers is part of
the noise it measures (``sqrt(sigma^2 + 1/12)`` when ``sigma`` is added before rounding).

A real sensor's noise grows with brightness (shot noise), so one figure per image depends on what the
image shows. :func:`noise_level_curve` gives the estimate per brightness bin (3x3 local mean), over the
flattest pixels of each bin and without pixels whose 3x3 neighbourhood touches 0 or 255 (clipped pixels
have no noise), and :func:`fit_shot_read_noise` fits the shot + read noise model of
``sim.sensors.photometric`` to it: ``sigma^2 = K S + r^2 + 1/12``.
"""
from __future__ import annotations

import cv2
import numpy as np

from scipy.optimize import nnls

from vo.errors import VoError

_KERNEL = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)


def estimate_noise_sigma(img: np.ndarray, flat_fraction: float = 0.2) -> float:
    """Noise std (grey levels) of a (H,W) image, H, W >= 3 (module docstring)."""
    img = _check(img, flat_fraction, "estimate_noise_sigma")
    if img.dtype == np.uint8:
        return _estimate_uint8(img, flat_fraction)
    r, g = _laplacian_sobel(img)
    flat = g <= np.quantile(g, flat_fraction)
    return _immerkaer(r[flat])


def _estimate_uint8(img: np.ndarray, flat_fraction: float) -> float:
    """:func:`estimate_noise_sigma` of an 8-bit image in integer arithmetic, to the same float: both filter
    responses of 8-bit pixels are integers (|Laplacian difference| <= 4080, Sobel magnitude <= 2040, exact in
    16 bits), so the ``flat_fraction`` quantile of the Sobel magnitude (NumPy's default linear interpolation
    between the order statistics at ``floor`` and ``floor + 1`` of ``(n - 1) flat_fraction``) is found from
    its histogram, and the mean of the integer responses up to it is an exact integer sum over the count.
    ~1 ms of CPU against ~5 ms for sorting the float image (``tests/test_frontend_lk_noise.py`` checks that the
    two give the same float)."""
    r = _abs16(cv2.filter2D(img, cv2.CV_16S, _KERNEL))[1:-1, 1:-1]
    g = cv2.add(_abs16(cv2.Sobel(img, cv2.CV_16S, 1, 0)), _abs16(cv2.Sobel(img, cv2.CV_16S, 0, 1)))[1:-1, 1:-1]
    g, r = np.ascontiguousarray(g).view(np.uint16), np.ascontiguousarray(r)
    n = g.size
    virtual = (n - 1) * float(flat_fraction)
    lo = min(int(np.floor(virtual)), n - 1)
    below = np.cumsum(cv2.calcHist([g], [0], None, [4096], [0, 4096]).ravel().astype(np.int64))   # count <= v
    v_lo = int(np.searchsorted(below, lo, side="right"))         # the order statistics at lo and lo + 1
    v_hi = int(np.searchsorted(below, min(lo + 1, n - 1), side="right"))
    gamma = virtual - lo                                          # NumPy's interpolated quantile, as np.quantile
    q = v_hi - (v_hi - v_lo) * (1.0 - gamma) if gamma >= 0.5 else v_lo + (v_hi - v_lo) * gamma
    flat = (g <= (v_hi if q >= v_hi else v_lo)).view(np.uint8)         # 1 where flat
    total = cv2.sumElems(cv2.bitwise_and(r, r, mask=flat))[0]    # an integer sum, exact in double
    return float(np.sqrt(np.pi / 2.0) * (total / cv2.countNonZero(flat)) / 6.0)


def _abs16(a: np.ndarray) -> np.ndarray:
    """|a| of a CV_16S image (exact below 32768)."""
    return cv2.absdiff(a, np.zeros_like(a))


def _check(img: np.ndarray, flat_fraction: float, name: str) -> np.ndarray:
    img = np.asarray(img)
    if img.ndim != 2 or min(img.shape) < 3:
        raise VoError(f"{name}: expected a (H,W) image with H, W >= 3, got shape {img.shape}")
    if not 0.0 < flat_fraction <= 1.0:
        raise VoError(f"{name}.flat_fraction: {flat_fraction!r}; must be in (0, 1]")
    return img


def _laplacian_sobel(img: np.ndarray):
    """(H-2,W-2) |Laplacian difference| and Sobel magnitude of the interior pixels."""
    f = img.astype(np.float32)
    r = np.abs(cv2.filter2D(f, -1, _KERNEL))[1:-1, 1:-1]
    g = (np.abs(cv2.Sobel(f, -1, 1, 0)) + np.abs(cv2.Sobel(f, -1, 0, 1)))[1:-1, 1:-1]
    return r, g


def _immerkaer(responses: np.ndarray) -> float:
    return float(np.sqrt(np.pi / 2.0) * responses.mean(dtype=np.float64) / 6.0)


def noise_level_curve(img: np.ndarray, bin_edges=None, flat_fraction: float = 0.2, min_pixels: int = 2000):
    """Noise std per brightness bin of a (H,W) 8-bit image (module docstring).

    ``bin_edges`` (B+1,) grey levels of the 3x3 local mean, default 0, 16, ..., 256. Returns ``levels``
    (M,) bin centres, ``sigmas`` (M,) and ``counts`` (M,) unclipped pixels, for the M <= B bins holding at
    least ``min_pixels`` unclipped pixels."""
    img = _check(img, flat_fraction, "noise_level_curve")
    edges = np.arange(0, 257, 16) if bin_edges is None else np.asarray(bin_edges, float)
    r, g = _laplacian_sobel(img)
    f = img.astype(np.float32)
    mean = cv2.blur(f, (3, 3))[1:-1, 1:-1]
    lo, hi = cv2.erode(f, np.ones((3, 3))), cv2.dilate(f, np.ones((3, 3)))
    unclipped = ((lo > 0) & (hi < 255))[1:-1, 1:-1]
    levels, sigmas, counts = [], [], []
    for a, b in zip(edges[:-1], edges[1:]):
        m = unclipped & (mean >= a) & (mean < b)
        if m.sum() < min_pixels:
            continue
        gm, rm = g[m], r[m]
        levels.append(0.5 * (a + b))
        sigmas.append(_immerkaer(rm[gm <= np.quantile(gm, flat_fraction)]))
        counts.append(int(m.sum()))
    return np.array(levels), np.array(sigmas), np.array(counts)


def fit_shot_read_noise(levels, sigmas):
    """Shot-noise gain ``K`` (grey levels per electron) and read noise ``r`` (grey levels), both >= 0,
    from a noise curve: least squares (``scipy.optimize.nnls``) of ``sigma^2 - 1/12 = K S + r^2`` over
    the (M,) ``levels`` ``S``, M >= 2, each level weighted alike."""
    levels, sigmas = np.asarray(levels, float), np.asarray(sigmas, float)
    if levels.shape != sigmas.shape or levels.size < 2:
        raise VoError(f"fit_shot_read_noise: need >= 2 matching levels and sigmas, got {levels.shape}, {sigmas.shape}")
    (gain, read2), _ = nnls(np.c_[levels, np.ones_like(levels)], sigmas ** 2 - 1.0 / 12.0)
    return float(gain), float(np.sqrt(read2))
