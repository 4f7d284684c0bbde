"""Epipolar gate around the stereo rig's residual vertical disparity, estimated per frame.

A real stereo rig's rectification (its written calibration) is never exact: a principal-point error or a
small rotation between the cameras moves every right-image point off the calibrated epipolar line by
nearly the same signed amount (a row offset; on cart27's 720x480 images a 0.04 deg roll adds at most
0.25 px across the image). Seed 003 gates stereo matches at 1 px from the line; with a residual offset
of 1.3 px (the ``realistic`` preset's calibration error on ``indoor-realistic`` seed 11) that gate
rejects ~90 % of correct matches. Here the offset is estimated from the frame's own matches and the
gate is seed 003's tolerance around it:

- ``r_i`` signed symmetric epipolar distance of match ``i`` (undistorted pixels; ``|r_i|`` is
  :func:`vo.frontend.stereo.epipolar_distances`, the sign that of ``x1^T F x0``);
- over the matches passed in (those LK's forward-backward check kept), ``m = median(r)``, then
  ``offset = median(r_i : |r_i - m| < threshold_px)`` (one trimmed step, so that the
  wrong matches a blank or repetitive view leaves far from the line weigh less);
  ``spread = 1.4826 MAD(r)`` around it;
- the offset is used when at least ``min_matches`` matches were given and ``|offset| <= max_offset_px``
  (a larger one is no rectification residual but a failure: the gate then stays around 0);
- a match passes when ``|r_i - offset| < threshold_px``.

With an exact calibration the offset is the median of the noise (a few hundredths of a pixel), so
the gate is seed 003's. The estimate is made from the current frame alone (no state across frames).
Not in seed 003; its 1 px tolerance is kept unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.frontend.stereo import fundamental_from_rig, signed_epipolar_distances, undistort_px

MAD_TO_SIGMA = 1.4826      # Gaussian std / median absolute deviation


@dataclass(frozen=True)
class RowOffset:
    """The frame's estimate: ``offset`` (px, 0 when not used), ``spread`` (1.4826 MAD, px; nan when
    fewer than 2 matches), ``n`` matches it was estimated from, ``used`` whether the gate moved."""

    offset: float
    spread: float
    n: int
    used: bool


def estimate_row_offset(r: np.ndarray, min_matches: int = 10, max_offset_px: float = 3.0,
                        threshold_px: float = 1.0) -> RowOffset:
    """Robust offset of signed epipolar distances ``r`` (N,) -> :class:`RowOffset` (module docstring)."""
    r = np.asarray(r, dtype=np.float64).reshape(-1)
    r = r[np.isfinite(r)]
    if len(r) == 0:
        return RowOffset(0.0, float("nan"), 0, False)
    med = float(np.median(r))
    near = np.abs(r - med) < threshold_px
    med = float(np.median(r[near])) if near.any() else med
    spread = float(MAD_TO_SIGMA * np.median(np.abs(r - med))) if len(r) >= 2 else float("nan")
    used = len(r) >= min_matches and abs(med) <= max_offset_px
    return RowOffset(med if used else 0.0, spread, len(r), used)


def offset_epipolar_mask(rig, p_left_px: np.ndarray, p_right_px: np.ndarray, threshold_px: float = 1.0,
                         min_matches: int = 10, max_offset_px: float = 3.0) -> tuple:
    """(N,) bool: raw left/right pixel pairs within ``threshold_px`` of the calibrated epipolar line
    shifted by the pairs' own robust offset -> ``(ok, RowOffset)``. ``min_matches = 0`` with
    ``max_offset_px = 0`` is the plain gate of :func:`vo.frontend.stereo.epipolar_mask`."""
    x0 = undistort_px(p_left_px, rig.cameras[0])
    x1 = undistort_px(p_right_px, rig.cameras[1])
    r = signed_epipolar_distances(fundamental_from_rig(rig), x0, x1)
    est = estimate_row_offset(r, min_matches, max_offset_px, threshold_px)
    return np.abs(r - est.offset) < threshold_px, est
