"""Image grid of square cells (seed 003, section 4.1 / 5.3): occupancy, empty cells, border cells.

Cells are ``cell`` x ``cell`` pixels, row-major, index ``k = row * n_cols + col``. When the image size is
not a multiple of ``cell`` (seed 003's own 752-pixel EuRoC width is not a multiple of 32) the last
column / row of cells is partial; it still counts as a cell (it is also a border cell).
Border cells (touching the image border) are skipped for detection so that the LK patch around a
detected corner lies inside the image (seed 003 section 5.4).
"""
from __future__ import annotations

import math

import numpy as np

from vo.errors import VoError


class Grid:
    """``Grid(width, height, cell=32)``; points are (N,2) pixel coordinates ``(u, v)``."""

    def __init__(self, width: int, height: int, cell: int = 32):
        for name, v in (("width", width), ("height", height), ("cell", cell)):
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v <= 0:
                raise VoError(f"Grid.{name}: must be a positive integer, got {v!r}")
        self.width, self.height, self.cell = int(width), int(height), int(cell)
        self.n_cols = math.ceil(self.width / self.cell)
        self.n_rows = math.ceil(self.height / self.cell)
        rows, cols = np.divmod(np.arange(self.n_cells), self.n_cols)
        self.is_border = (rows == 0) | (cols == 0) | (rows == self.n_rows - 1) | (cols == self.n_cols - 1)

    @property
    def n_cells(self) -> int:
        return self.n_rows * self.n_cols

    def cell_index(self, pts: np.ndarray) -> np.ndarray:
        """(N,2) pixels -> (N,) int cell index; -1 for points outside the image."""
        p = np.asarray(pts, dtype=float).reshape(-1, 2)
        inside = (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 0] < self.width) & (p[:, 1] < self.height)
        inside &= np.all(np.isfinite(p), axis=1)
        col = np.floor(np.where(inside, p[:, 0], 0) / self.cell).astype(int)
        row = np.floor(np.where(inside, p[:, 1], 0) / self.cell).astype(int)
        return np.where(inside, row * self.n_cols + col, -1)

    def counts(self, pts: np.ndarray) -> np.ndarray:
        """(n_cells,) int number of points in each cell."""
        idx = self.cell_index(pts)
        return np.bincount(idx[idx >= 0], minlength=self.n_cells)

    def empty_cells(self, pts: np.ndarray) -> np.ndarray:
        """Indices of cells holding no point (border cells included)."""
        return np.flatnonzero(self.counts(pts) == 0)

    def empty_fraction(self, pts: np.ndarray) -> float:
        """Empty cells / all cells (seed 003's keyframe quantity, 'max. empty cells percentage')."""
        return float(self.empty_cells(pts).size) / self.n_cells

    def detection_cells(self, pts: np.ndarray) -> np.ndarray:
        """Empty, non-border cells: where new corners are detected on a keyframe."""
        empty = self.empty_cells(pts)
        return empty[~self.is_border[empty]]

    def best_in_cells(self, score: np.ndarray, last: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Per-cell maximum of a (height, width) ``score`` image -> ``(best (n_cells,), uv (n_cells, 2))``,
        ``uv`` the integer pixel of the maximum; ties go to the first pixel in row-major order within the
        cell, or the last with ``last`` (as ``cv2.goodFeaturesToTrack`` sorts equal scores)."""
        c = self.cell
        pad = np.full((self.n_rows * c, self.n_cols * c), -np.inf, np.float32)
        pad[:self.height, :self.width] = score
        blocks = pad.reshape(self.n_rows, c, self.n_cols, c).transpose(0, 2, 1, 3).reshape(self.n_cells, c * c)
        k = c * c - 1 - np.argmax(blocks[:, ::-1], axis=1) if last else np.argmax(blocks, axis=1)
        row, col = np.divmod(np.arange(self.n_cells), self.n_cols)
        uv = np.c_[col * c + k % c, row * c + k // c].astype(np.float64)
        return blocks[np.arange(self.n_cells), k], uv

    def cell_rect(self, k: int) -> tuple:
        """Cell ``k`` -> ``(x0, y0, x1, y1)`` pixel bounds, half-open, clipped to the image."""
        row, col = divmod(int(k), self.n_cols)
        x0, y0 = col * self.cell, row * self.cell
        return x0, y0, min(x0 + self.cell, self.width), min(y0 + self.cell, self.height)
