"""Image conversions shared by the simulator's sensors and writers and the estimators' front-ends."""
from __future__ import annotations

import cv2
import numpy as np


def to_gray(img: np.ndarray) -> np.ndarray:
    """(H,W) grey or (H,W,3) RGB image -> (H,W) uint8, C-contiguous.

    Colour uses OpenCV's ``COLOR_RGB2GRAY`` weights (0.299 R + 0.587 G + 0.114 B, RGB channel order);
    a non-uint8 image is clipped to 0..255 and truncated to uint8; a grey uint8 image is returned as is
    when already contiguous."""
    a = np.asarray(img)
    if a.ndim == 3:
        a = cv2.cvtColor(a, cv2.COLOR_RGB2GRAY)
    if a.dtype != np.uint8:
        a = np.clip(a, 0, 255).astype(np.uint8)
    return np.ascontiguousarray(a)
