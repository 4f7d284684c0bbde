"""Photometric camera effects: vignetting, auto exposure, and a shot + read noise sensor model.

- Vignetting (``camera.vignetting = s``): the natural cos^4 fall-off of irradiance with the angle
  ``theta`` of a pixel's ray to the optical axis, scaled by ``s``: factor ``1 - s (1 - cos^4 theta)``
  (``s = 1``: full cos^4, 0.59 at the corners of a 90 deg-diagonal lens).
- Auto exposure (``camera.auto_exposure``): one gain for both cameras (a stereo master, as the EuRoC
  MT9V034 pair), applied to frame ``k`` from the brightness of frames ``< k``: the gain that would put
  the previous frame's mean (at unit gain) at ``ae_target x 255`` is approached exponentially with time
  constant ``ae_time_constant_s``; it starts at 1 and is kept in [1/4, 4].
- Sensor noise (``camera.read_noise_dn`` = r, ``camera.shot_noise_gain`` = K grey levels per electron):
  a pixel of signal ``S`` grey levels collects ``S / K`` electrons (Poisson) and gets Gaussian read noise,
  ``value = K Poisson(S / K) + r N(0, 1)``, so ``var = K S + r^2`` (plus 1/12 from rounding to 8 bits).
"""
from __future__ import annotations

import numpy as np

GAIN_RANGE = (0.25, 4.0)


def vignetting_map(cam, strength: float) -> np.ndarray:
    """(H,W) float32 factor ``1 - strength (1 - cos^4 theta)`` of the pinhole camera ``cam`` (rigs.model.Camera)."""
    u = (np.arange(cam.width) - cam.cx) / cam.fx
    v = (np.arange(cam.height) - cam.cy) / cam.fy
    cos2 = 1.0 / (1.0 + u[None, :] ** 2 + v[:, None] ** 2)
    return (1.0 - strength * (1.0 - cos2 ** 2)).astype(np.float32)


class AutoExposure:
    """The exposure gain state (module docstring); :meth:`gain` for the next frame, :meth:`update` after it."""

    def __init__(self, target: float, time_constant_s: float, period_s: float):
        self.target_dn = 255.0 * target
        self.alpha = 1.0 - float(np.exp(-period_s / time_constant_s))
        self.gain = 1.0

    def update(self, mean_at_unit_gain: float) -> None:
        """Move the gain toward the one that would map ``mean_at_unit_gain`` to the target."""
        wanted = self.target_dn / max(mean_at_unit_gain, 1e-3)
        self.gain = float(np.clip(self.gain + self.alpha * (wanted - self.gain), *GAIN_RANGE))


def quantize(img: np.ndarray) -> np.ndarray:
    """Float grey levels -> uint8 (round, clip to 0..255)."""
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def sensor_noise(img: np.ndarray, read_dn: float, gain_dn_per_e: float, rng: np.random.Generator) -> np.ndarray:
    """Shot + read noise on a float image of grey levels (module docstring), quantized to uint8.
    Draws, in order: the Poisson electron counts (when ``gain_dn_per_e > 0``), then the read noise
    (when ``read_dn > 0``)."""
    x = np.clip(np.asarray(img, np.float64), 0.0, None)
    if gain_dn_per_e > 0:
        x = gain_dn_per_e * rng.poisson(x / gain_dn_per_e)
    if read_dn > 0:
        x = x + rng.normal(0.0, read_dn, x.shape)
    return quantize(x)


def noise_variance(signal_dn, read_dn: float, gain_dn_per_e: float) -> np.ndarray:
    """The model's variance (grey levels^2) at ``signal_dn`` before rounding: ``K S + r^2``."""
    return gain_dn_per_e * np.asarray(signal_dn, np.float64) + read_dn ** 2
