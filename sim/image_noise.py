"""Image sensor noise as a separate measurement step: ``measure(truth, rng)``."""
from __future__ import annotations

import numpy as np

from sim.errors import SimError


def add_image_noise(img: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Add i.i.d. Gaussian noise of std ``sigma`` (grey levels) to a uint8 image, round, clip.

    ``img``: (H,W) or (H,W,3) uint8; returns a new uint8 array of the same shape. ``sigma = 0``
    returns an unchanged copy and draws nothing from ``rng``.
    """
    if not np.isfinite(sigma) or sigma < 0:
        raise SimError(f"image_noise.sigma: must be a finite number >= 0, got {sigma!r}")
    if img.dtype != np.uint8:
        raise SimError(f"image_noise: expected a uint8 image, got dtype {img.dtype}")
    if sigma == 0:
        return img.copy()
    noisy = img.astype(np.float32) + rng.normal(0.0, sigma, size=img.shape).astype(np.float32)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
