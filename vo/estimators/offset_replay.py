"""The start-up of the online disparity offset: re-chaining the frames tracked before it was known.

:class:`~vo.estimators.disparity_offset.DisparityOffset` reports an offset only once several keyframes have been
fitted (on the real KITTI turn from frame 6-9). Until then ``klt-pnp`` chains its poses on landmarks placed at
the uncorrected (long) stereo depths, so every step is long, and correcting the landmarks' depths from then on
leaves the current pose where the long steps put it (on the turn: 2.85 % end drift, against 1.53 % with the
offset known from the first frame; docs/estimators.md).

As monocular and visual-inertial SLAM systems rescale their map once initialisation fixes the scale, the
estimator then corrects its *current state*: :class:`ChainRecord` keeps, since the last (re)initialisation, each
frame's pose, the landmarks it tracked (PnP inliers: ids, undistorted pixels) and the landmarks born on it (raw
stereo points in its left camera); :meth:`ChainRecord.replay` places each birth at its corrected depth
``z' = f b / (f b / z + delta)`` along its ray, in the birth frame's re-chained pose, and refits every later
frame's pose on those landmarks (``cv2.solvePnPRefineLM`` on the inliers that frame kept, started from the
re-chained previous pose times the original step). The first frame of the record (the keyframe that defines the
odometry frame, or a re-initialisation) keeps its pose. The poses already emitted stay as they were; only the
current pose, the velocity and the landmarks change. The record holds at most ``max_frames`` frames (the
oldest kept one is then the anchor) and takes the re-chained poses, so that a later replay (when the offset
estimate has moved by more than ``replay_step_px``) starts from them.

Not in seed 003 (whose calibration is consistent); on a consistent calibration no offset is applied, nothing is
replayed and ``klt-pnp`` is unchanged.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from rigs.geometry import inv_T, transform_points
from vo.estimators.rigidity import refine_pose

MIN_REFIT_POINTS = 6         # landmarks a frame needs for its refit (else it keeps the original step)


@dataclass(frozen=True)
class ChainFrame:
    """One recorded frame: pose ``T_o_c0`` (4,4) as estimated; ``ids`` (N,) and undistorted pixels ``px`` (N,2)
    of the landmarks it tracked; ``born`` (M,) ids and raw stereo points ``p_c`` (M,3) (its left camera) of the
    landmarks born on it."""

    T_o_c0: np.ndarray
    ids: np.ndarray
    px: np.ndarray
    born: np.ndarray
    p_c: np.ndarray


@dataclass(frozen=True)
class Replay:
    """The re-chained record: ``pairs`` ``(T_old, T_new)`` (4,4) per frame, oldest first (the last is the
    current frame); ``raw_o`` id -> the landmark's raw stereo point (3,) in its re-chained birth camera, for
    the landmarks born within the record."""

    pairs: list
    raw_o: dict

    def moved(self) -> dict:
        """Camera centre of an old pose (its bytes: stored centres and poses are copies of the estimator's pose,
        equal to the bit) -> ``(T_new (4,4), R_new_old (3,3))``, the new pose and the rotation taking old
        odometry-frame directions to new ones."""
        out = {}
        for T_old, T_new in self.pairs:
            T_old, T_new = np.asarray(T_old, float), np.asarray(T_new, float)
            out[T_old[:3, 3].tobytes()] = (T_new.copy(), T_new[:3, :3] @ T_old[:3, :3].T)
        return out


def rebased_near(near: dict, moved: dict) -> dict:
    """``klt-pnp``'s close/far records (track id -> ``(near, birth c_o (3,), birth bearing_o (3,))``) with the
    births at a re-chained pose (``Replay.moved()``) moved to its new centre and bearing."""
    out = dict(near)
    for i, (is_near, c, d) in near.items():
        if c.tobytes() in moved:
            T_new, R_new_old = moved[c.tobytes()]
            out[i] = (is_near, T_new[:3, 3].copy(), R_new_old @ d)
    return out


class ChainRecord:
    """Frames since the last (re)initialisation (module docstring). Per frame, first the births
    (:meth:`born`, any number of calls), then :meth:`frame` closes it with its pose and tracked landmarks."""

    def __init__(self, max_frames: int):
        self.max_frames = int(max_frames)
        self.frames: deque = deque(maxlen=max(self.max_frames, 1))
        self._born: list = []

    def reset(self) -> None:
        """A (re)initialisation: the chain starts anew."""
        self.frames.clear()
        self._born = []

    def born(self, ids, p_c: np.ndarray) -> None:
        """Landmarks ``ids`` (M,) born on the current frame at raw stereo points ``p_c`` (M,3) in its left camera."""
        if self.max_frames > 0 and len(ids):
            self._born.append((np.asarray(ids, np.int64).copy(), np.asarray(p_c, float).reshape(-1, 3).copy()))

    def frame(self, T_o_c0: np.ndarray, ids, px: np.ndarray) -> None:
        """Close the current frame: its pose ``T_o_c0`` (4,4), tracked landmarks ``ids`` (N,) at undistorted
        pixels ``px`` (N,2) (those born on it may be among them: they are not used for its own pose)."""
        if self.max_frames <= 0:
            return
        born = [b[0] for b in self._born]
        p_c = [b[1] for b in self._born]
        self.frames.append(ChainFrame(np.asarray(T_o_c0, float).copy(), np.asarray(ids, np.int64).copy(),
                                      np.asarray(px, float).reshape(-1, 2).copy(),
                                      np.concatenate(born) if born else np.zeros(0, np.int64),
                                      np.concatenate(p_c) if p_c else np.zeros((0, 3))))
        self._born = []

    def replay(self, delta_px: float, fb: float, K: np.ndarray) -> Replay | None:
        """The record re-chained with every birth at the depth the offset ``delta_px`` gives (``fb`` = focal
        length (px) times baseline (m); ``K`` (3,3) of the undistorted pixels) -> :class:`Replay`, or None when
        fewer than two frames are recorded."""
        if len(self.frames) < 2:
            return None
        K = np.asarray(K, np.float64)
        corrected: dict = {}                 # id -> corrected p_o in the re-chained frame
        raw_o: dict = {}
        pairs = []
        T_prev_old = T_prev_new = None
        for fr in self.frames:
            if T_prev_old is None:
                T_new = fr.T_o_c0.copy()
            else:
                T_new = T_prev_new @ inv_T(T_prev_old) @ fr.T_o_c0
                T_new = _refit(T_new, fr, corrected, K)
            if len(fr.born):
                z = fr.p_c[:, 2]
                z_new = fb / (fb / z + delta_px)
                p_o_raw = transform_points(T_new, fr.p_c)
                p_o = transform_points(T_new, fr.p_c * (z_new / z)[:, None])
                for i, pr, pc in zip(fr.born.tolist(), p_o_raw, p_o):
                    raw_o[i], corrected[i] = pr, pc
            pairs.append((fr.T_o_c0, T_new))
            T_prev_old, T_prev_new = fr.T_o_c0, T_new
        self.frames = deque((ChainFrame(T_new, fr.ids, fr.px, fr.born, fr.p_c)
                             for fr, (_, T_new) in zip(self.frames, pairs)), maxlen=self.frames.maxlen)
        return Replay(pairs, raw_o)


def _refit(T_o_c0: np.ndarray, fr: ChainFrame, corrected: dict, K: np.ndarray) -> np.ndarray:
    """Frame ``fr``'s pose refitted (LM, started at ``T_o_c0``) on its tracked landmarks that were born earlier
    in the record, at their corrected positions; ``T_o_c0`` itself with fewer than :data:`MIN_REFIT_POINTS`."""
    use = np.array([i in corrected for i in fr.ids.tolist()], bool)
    if use.sum() < MIN_REFIT_POINTS:
        return T_o_c0
    p_o = np.array([corrected[i] for i in fr.ids[use].tolist()], np.float64)
    try:
        T = refine_pose(inv_T(T_o_c0), p_o, fr.px[use], K)
    except cv2.error:
        return T_o_c0
    return inv_T(T) if np.all(np.isfinite(T)) else T_o_c0
