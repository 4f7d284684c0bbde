"""The four estimated ROPs of one epoch pair plus the calibrated stereo ROP; exact ROPs from poses.

Pairs are named ``"13", "14", "23", "24"`` (image i, image j): the ROP of image j in image i's
frame. The calibrated ROP ``T_c1_c2`` (= ``T_c3_c4`` = the rig's ``T_c0_c1``) is given in metres.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.errors import EstimatorError
from rigs.geometry import inv_T
from vo.rop.relative import RopMeasurement

PAIRS = ("13", "14", "23", "24")
WEIGHTINGS = ("inliers", "sampson")


@dataclass(frozen=True)
class RopSet:
    """``rops``: dict pair -> :class:`RopMeasurement` (not-ok entries are ignored);
    ``T_c1_c2`` (4,4) calibrated stereo ROP (also ``T_c3_c4``); ``weighting`` "inliers" (seed 000)
    or "sampson" (our extension, see :meth:`weights`)."""

    rops: dict
    T_c1_c2: np.ndarray
    weighting: str = "inliers"

    def __post_init__(self):
        bad = sorted(set(self.rops) - set(PAIRS))
        if bad:
            raise EstimatorError(f"RopSet.rops: unknown pair(s) {bad}; valid: {', '.join(PAIRS)}")
        T = np.asarray(self.T_c1_c2, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)) or np.linalg.norm(T[:3, 3]) <= 0:
            raise EstimatorError(f"RopSet.T_c1_c2: expected a finite 4x4 transform with a non-zero baseline, got {T!r}")
        object.__setattr__(self, "T_c1_c2", T)
        if self.weighting not in WEIGHTINGS:
            raise EstimatorError(f"RopSet.weighting: {self.weighting!r}; valid: {', '.join(WEIGHTINGS)}")

    @property
    def ok_pairs(self) -> tuple:
        """The pairs with a usable measurement, in :data:`PAIRS` order."""
        return tuple(p for p in PAIRS if p in self.rops and self.rops[p].ok)

    def weights(self, part: str = "rot") -> dict:
        """pair -> weight over the ok pairs, normalised to mean 1.

        ``"inliers"`` (seed 000: weights from RANSAC): ``n_inliers / mean(n_inliers)`` for both parts.
        ``"sampson"`` (our extension; the paper is silent on anything but inlier counts):
        ``1 / sigma_p^2`` of the ROP's own Sampson fit, ``sigma_rot_rad`` for ``part="rot"``,
        ``sigma_dir_rad`` for ``part="dir"`` (inverse-variance weights: an ill-conditioned essential
        matrix - forward motion towards a wall - gets a large sigma and a small weight). ROPs without
        a sigma (exact / synthetic) fall back to inlier counts."""
        ok = self.ok_pairs
        if not ok:
            return {}
        sig = [getattr(self.rops[p], "sigma_rot_rad" if part == "rot" else "sigma_dir_rad") for p in ok]
        if self.weighting == "sampson" and all(s is not None and s > 0 for s in sig):
            w = 1.0 / np.square(np.array(sig, dtype=float))
        else:
            w = np.array([max(self.rops[p].n_inliers, 1) for p in ok], dtype=float)
        return {p: float(x) for p, x in zip(ok, w / w.mean())}

    @property
    def R_1_2(self) -> np.ndarray:
        return self.T_c1_c2[:3, :3]

    @property
    def t_1_2(self) -> np.ndarray:
        return self.T_c1_c2[:3, 3]

    @property
    def baseline(self) -> float:
        return float(np.linalg.norm(self.T_c1_c2[:3, 3]))


def camera_poses(T_c1_c3: np.ndarray, T_c1_c2: np.ndarray) -> dict:
    """Poses ``T_c1_ck`` (4,4) of the four images, k = 1..4, for a left-camera motion ``T_c1_c3``."""
    return {1: np.eye(4), 2: np.asarray(T_c1_c2, float), 3: np.asarray(T_c1_c3, float),
            4: np.asarray(T_c1_c3, float) @ np.asarray(T_c1_c2, float)}


def exact_ropset(T_c1_c3: np.ndarray, T_c1_c2: np.ndarray, n_inliers=100) -> RopSet:
    """The exact four ROPs for a motion ``T_c1_c3``; ``n_inliers`` an int or dict pair -> int."""
    T = camera_poses(T_c1_c3, T_c1_c2)
    rops = {}
    for p in PAIRS:
        T_i_j = inv_T(T[int(p[0])]) @ T[int(p[1])]
        n = n_inliers[p] if isinstance(n_inliers, dict) else int(n_inliers)
        rops[p] = RopMeasurement(T_i_j[:3, :3], T_i_j[:3, 3] / np.linalg.norm(T_i_j[:3, 3]),
                                 n, np.ones(n, dtype=bool), True)
    return RopSet(rops, np.asarray(T_c1_c2, float))
