"""The translation of a coasted frame: the median of the last measured steps, not the last one alone.

Our extension (seed 003 has no failure policy). A stereo PnP estimator that cannot fit a pose coasts at constant
velocity (:mod:`vo.estimators.pnp`): the step repeated is its translation in the previous camera (with the
rotation of :mod:`vo.estimators.coast_rotation` where the tracks measure one). Frames fail where the view runs
out of texture, and the last fitted steps before such a failure are fitted on the few landmarks left, bunched on
one surface, where a PnP can trade yaw for sideways translation: on ``indoor-realistic`` seed 23 (the blank-wall
turn) the two steps before five coasted frames were fitted on 18 and 13-14 inliers and were 8.7-10.3 cm off
against a true step of about 7.5 cm; repeating the last one put 8-10 cm of error into every coasted step
(docs/estimators.md). A vehicle's velocity does not change that much in one frame; the component-wise median of
the last :data:`COAST_STEPS` measured steps' translations (each in the camera it started from) is the velocity
of the last ones that agree: one or two wrong steps among five do not move it, and on a steady motion it is the
constant-velocity translation itself.

The history holds measured steps only (coasted ones are not measurements); when the chain is re-estimated
(:mod:`vo.estimators.offset_replay`), :meth:`StepHistory.rebase` takes the re-chained poses' steps.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from rigs.geometry import inv_T

COAST_STEPS = 5          # measured steps whose median translation a coasted frame takes (2 wrong ones tolerated)


class StepHistory:
    """The translations (3,) of the last :data:`COAST_STEPS` measured steps ``T_prev_curr``, oldest first."""

    def __init__(self, n: int = COAST_STEPS):
        self.steps: deque = deque(maxlen=int(n))

    def push(self, T_prev_curr: np.ndarray) -> None:
        """A measured step (4,4): the previous camera's pose to the current one's."""
        self.steps.append(np.asarray(T_prev_curr, float)[:3, 3].copy())

    def rebase(self, poses) -> None:
        """The chain re-estimated: the steps between consecutive re-chained poses ``T_o_c`` (4,4 each, oldest
        first, the last the current frame) replace the newest ones held."""
        poses = [np.asarray(T, float) for T in poses][-(self.steps.maxlen + 1):]
        steps = [(inv_T(a) @ b)[:3, 3] for a, b in zip(poses[:-1], poses[1:])]
        kept = list(self.steps)[:max(len(self.steps) - len(steps), 0)]
        self.steps = deque(kept + steps, maxlen=self.steps.maxlen)

    def translation(self, fallback: np.ndarray) -> np.ndarray:
        """The coasted step's translation (3,): the component-wise median of the held steps, ``fallback`` (3,)
        when none is held."""
        if not self.steps:
            return np.asarray(fallback, float).copy()
        return np.median(np.array(self.steps), axis=0)
