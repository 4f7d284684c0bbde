"""Where each four-view track should appear in the current left image: the start points of ``rop``'s temporal LK.

The same remedy as ``klt-pnp``'s (:mod:`vo.estimators.track_prediction`; not in seed 000 or 003): from zero flow
the pyramidal LK reaches only what its coarsest level sees, so at a third of the frame rate in a city turn both KLT
front-ends lose their tracks (docs/estimators.md, "Frame rate").

Each track's keyframe stereo pair ``(p1, p2)`` gives its point in the keyframe camera; seen from the predicted
pose ``T_kf_c`` (the estimator's motion prior, ``RopEstimator._prior``) through the left lens model it gives a
second start for the tracks that seed 003's zero-flow search loses where the prediction lies beyond that search's
reach (:attr:`vo.frontend.klt.KltConfig.reach_px`), and its mirror the backward search's
(:meth:`vo.rop.tracks.KltFourView.track`). Every track the zero-flow search holds stays as it is, and where the flow
stays within reach nothing changes (starting every track at its prediction, as ``klt-pnp`` does, moves ``rop``'s
indoor figures: docs/estimators.md, "Frame rate"). A track whose pair does not triangulate within ``max_depth``
(far, or a bad pair) is predicted on its keyframe ray at ``max_depth``: as a far point moves, by the rotation.

Shapes: ``p1``, ``p2`` (N,2) raw keyframe pixels (right corrected, :class:`vo.rop.tracks.KltFourView`); ``p3``
(N,2) current raw left pixels; result (N,2) raw pixels.
"""
from __future__ import annotations

import numpy as np

from vo.estimators.track_prediction import predicted_pixels
from vo.frontend.stereo import triangulate


def predicted_left(rig, T_kf_c: np.ndarray, p1: np.ndarray, x1: np.ndarray, p2: np.ndarray, p3: np.ndarray,
                   max_depth: float, max_triangulation_px: float) -> np.ndarray:
    """The tracks' keyframe points (``p1``/``p2`` triangulated; else the normalised ray ``x1`` (N,2) at
    ``max_depth``) seen from ``T_kf_c`` (4,4) in the left camera (:func:`predicted_pixels`: behind the camera
    or outside the image keeps ``p3``)."""
    p_kf, ok = triangulate(rig, p1, p2, max_depth, max_triangulation_px)
    far = np.c_[np.asarray(x1, np.float64).reshape(-1, 2), np.ones(len(p_kf))] * max_depth
    p_kf = np.where(ok[:, None], p_kf, far)
    return predicted_pixels(rig.cameras[0], T_kf_c, p_kf, p3)
