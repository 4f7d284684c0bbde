"""Vectorised seed-003 grid detection: the best Shi-Tomasi corner of every empty non-border cell.

Same rule as :func:`vo.frontend.klt.detect_in_empty_cells` (one corner per empty non-border cell,
minimum-eigenvalue score >= ``min_eigenvalue``) but one ``cv2.cornerMinEigenVal`` over the whole
image and a per-cell argmax in numpy instead of one ``goodFeaturesToTrack`` call per cell
(~1.5 ms instead of ~13 ms on 752x480). Corners are integer pixels, as goodFeaturesToTrack's are.
"""
from __future__ import annotations

import cv2
import numpy as np

from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig


def cell_maxima(eig: np.ndarray, cell: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-cell (row-major) maximum score and its (u, v) pixel -> ``(score (n,), uv (n,2))``."""
    h, w = eig.shape
    rows, cols = -(-h // cell), -(-w // cell)
    pad = np.full((rows * cell, cols * cell), -np.inf, np.float32)
    pad[:h, :w] = eig
    blocks = pad.reshape(rows, cell, cols, cell).transpose(0, 2, 1, 3).reshape(rows * cols, cell * cell)
    k = np.argmax(blocks, axis=1)
    score = blocks[np.arange(len(k)), k]
    r, c = np.divmod(np.arange(rows * cols), cols)
    uv = np.c_[c * cell + k % cell, r * cell + k // cell].astype(np.float64)
    return score, uv


def detect_grid(img: np.ndarray, grid: Grid, existing_pts: np.ndarray, config: KltConfig = KltConfig()) -> np.ndarray:
    """(H,W) uint8 -> (M,2) float64 corners, one per empty non-border cell of ``grid``."""
    cells = grid.detection_cells(existing_pts)
    if len(cells) == 0:
        return np.zeros((0, 2))
    eig = cv2.cornerMinEigenVal(img, config.block_size)
    score, uv = cell_maxima(eig, grid.cell)
    keep = cells[score[cells] >= config.min_eigenvalue]
    return uv[keep]
