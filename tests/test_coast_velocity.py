"""The coasted translation (``vo.estimators.coast_velocity``) against exact steps."""
from __future__ import annotations

import numpy as np

from rigs.geometry import inv_T, make_T, rot_y
from vo.estimators.coast_velocity import COAST_STEPS, StepHistory


def _step(t, yaw_deg=0.0):
    return make_T(rot_y(np.radians(yaw_deg)), t)


def test_median_of_the_last_steps_ignores_two_odd_ones():
    """Five measured steps, three of them the steady (0.01, 0, 0.08) m and two off sideways by 5 and 9 cm: the
    median is the steady step exactly; the oldest steps leave the window."""
    h = StepHistory()
    assert np.array_equal(h.translation(np.array([1.0, 2.0, 3.0])), [1.0, 2.0, 3.0])     # none held: fallback
    for t in ([0.5, 0.5, 0.5], [0.01, 0.0, 0.08], [0.01, 0.0, 0.08], [0.01, 0.0, 0.08], [0.06, 0.0, 0.08],
              [-0.08, 0.0, 0.08]):
        h.push(_step(t, 1.0))
    assert len(h.steps) == COAST_STEPS
    assert np.allclose(h.translation(np.zeros(3)), [0.01, 0.0, 0.08], atol=1e-15)


def test_rebase_takes_the_rechained_steps():
    """A re-chained record (poses of a constant step) replaces the held steps by its own exactly, the newest
    ones; a record shorter than the window keeps the older held steps before its own."""
    step = _step([0.01, 0.0, 0.08], 2.0)
    poses = [np.eye(4)]
    for _ in range(8):
        poses.append(poses[-1] @ step)
    h = StepHistory()
    for _ in range(COAST_STEPS):
        h.push(_step([0.2, 0.0, 0.1]))
    h.rebase(poses)
    assert len(h.steps) == COAST_STEPS
    assert all(np.allclose(s, step[:3, 3], atol=1e-12) for s in h.steps)
    h2 = StepHistory()
    for _ in range(COAST_STEPS):
        h2.push(_step([0.2, 0.0, 0.1]))
    h2.rebase(poses[:3])                       # two re-chained steps: the three oldest held stay
    assert [np.allclose(s, [0.2, 0.0, 0.1]) for s in h2.steps] == [True] * 3 + [False] * 2
    assert np.allclose(h2.steps[-1], (inv_T(poses[1]) @ poses[2])[:3, 3])
