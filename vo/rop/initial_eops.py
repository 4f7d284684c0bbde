"""Initial EOPs of images 3 and 4 from the ROPs alone (seed 000 section 2.3).

Seed 000 says only that the initial EOPs come "from the geometric relation among time-adjacent
stereo image pairs", with the scale from the calibrated baseline and no 3-D point cloud. We use:

* Rotation: every ROP gives one estimate of ``R_1_3``: ``R_1_3``, ``R_1_2 R_2_3``,
  ``R_1_4 R_3_4^T``, ``R_1_2 R_2_4 R_3_4^T``; their inlier-weighted chordal L2 mean
  (SVD projection of the weighted sum onto SO(3)). ``R_1_4 = R_1_3 R_3_4``.
* Position: the origin of C_3, ``c3``, lies on the ray from C_1 along ``rhat_1_3`` and on the ray
  from C_2 along ``R_1_2 rhat_2_3``; C_4 = ``c3 + R_1_3 t_3_4`` lies on the rays from C_1 along
  ``rhat_1_4`` and from C_2 along ``R_1_2 rhat_2_4``. One weighted linear least-squares problem in
  ``c3`` and the four ray lengths (12 equations, 7 unknowns) intersects all four rays at once; the
  calibrated baselines ``t_1_2`` and ``t_3_4`` fix the scale.
* Degeneracy: if the rays are (nearly) parallel - motion along the baseline, or no motion - the
  system is rank deficient. We report ``conditioning = s_min / s_max`` of the weighted design
  matrix and flag ``degenerate`` below ``min_conditioning``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vo.errors import EstimatorError
from rigs.geometry import make_T
from vo.rop.ropset import RopSet

MODES = ("network", "minimal")


@dataclass(frozen=True)
class InitialEops:
    """Initial ``R_1_3``, ``R_1_4`` (3,3) and origins ``t_1_3``, ``t_1_4`` (3,) of C_3, C_4 in C_1."""

    R_1_3: np.ndarray
    R_1_4: np.ndarray
    t_1_3: np.ndarray
    t_1_4: np.ndarray
    ray_lengths: dict          # pair -> distance along the ray (lambda of the ROP)
    conditioning: float        # s_min / s_max of the weighted intersection design matrix
    degenerate: bool
    message: str = ""

    @property
    def T_c1_c3(self) -> np.ndarray:
        return make_T(self.R_1_3, self.t_1_3)

    @property
    def T_c1_c4(self) -> np.ndarray:
        return make_T(self.R_1_4, self.t_1_4)


def project_to_so3(M: np.ndarray) -> np.ndarray:
    """(3,3) -> the nearest rotation in the Frobenius norm (SVD, det = +1)."""
    U, _, Vt = np.linalg.svd(M)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def chordal_mean(Rs, weights) -> np.ndarray:
    """Weighted chordal L2 mean of rotations (K,3,3) with weights (K,)."""
    return project_to_so3(np.einsum("k,kij->ij", np.asarray(weights, float), np.asarray(Rs, float)))


def rotation_candidates(rops: RopSet, pairs: tuple) -> tuple[list, list]:
    """Estimates of ``R_1_3`` (one per pair in ``pairs``) and their weights."""
    R12, R34 = rops.R_1_2, rops.R_1_2  # R_3_4 = R_1_2 (same calibrated rig)
    w = rops.weights("rot")
    via = {"13": lambda R: R, "23": lambda R: R12 @ R,
           "14": lambda R: R @ R34.T, "24": lambda R: R12 @ R @ R34.T}
    Rs = [via[p](rops.rops[p].R_i_j) for p in pairs]
    return Rs, [w[p] for p in pairs]


def intersect_rays(rops: RopSet, R_1_3: np.ndarray, pairs: tuple) -> tuple[np.ndarray, dict, float]:
    """Least-squares intersection -> ``c3`` (3,), ray lengths per pair, conditioning."""
    c2, o34 = rops.t_1_2, R_1_3 @ rops.t_1_2            # t_3_4 = t_1_2 (calibrated rig)
    origin = {"13": np.zeros(3), "23": c2, "14": -o34, "24": c2 - o34}   # c3 - s d = origin
    w = rops.weights("dir")
    M = np.zeros((3 * len(pairs), 3 + len(pairs)))
    b = np.zeros(3 * len(pairs))
    for k, p in enumerate(pairs):
        d = rops.rops[p].rhat_i_j if p[0] == "1" else rops.R_1_2 @ rops.rops[p].rhat_i_j
        sw = np.sqrt(w[p])
        M[3 * k:3 * k + 3, :3] = sw * np.eye(3)
        M[3 * k:3 * k + 3, 3 + k] = -sw * d
        b[3 * k:3 * k + 3] = sw * origin[p]
    if len(pairs) < 2:
        return np.zeros(3), {}, 0.0
    s = np.linalg.svd(M, compute_uv=False)
    x = np.linalg.lstsq(M, b, rcond=None)[0]
    return x[:3], {p: float(x[3 + k]) for k, p in enumerate(pairs)}, float(s[-1] / s[0])


def initial_eops(rops: RopSet, min_conditioning: float = 1e-3, mode: str = "network") -> InitialEops:
    """Initial EOPs of images 3 and 4 in C_1 (see the module docstring for the formulation).

    ``mode="network"`` uses every ok ROP; ``"minimal"`` only ROP 1-3 for the rotation and the rays
    1-3, 2-3 for ``c3`` (the simplest reading of seed 000; the baseline for Fig. 5's claim)."""
    if mode not in MODES:
        raise EstimatorError(f"initial_eops.mode: {mode!r}; valid: {', '.join(MODES)}")
    pairs = rops.ok_pairs if mode == "network" else tuple(p for p in ("13", "23") if p in rops.ok_pairs)
    if mode == "minimal" and pairs != ("13", "23"):
        pairs = rops.ok_pairs
    if not pairs:
        I = np.eye(3)
        return InitialEops(I, rops.R_1_2, np.zeros(3), rops.t_1_2, {}, 0.0, True, "no usable ROP")
    R_1_3 = chordal_mean(*rotation_candidates(rops, pairs[:1] if mode == "minimal" else pairs))
    c3, lengths, cond = intersect_rays(rops, R_1_3, pairs)
    degenerate = cond < min_conditioning
    msg = (f"rays nearly parallel (conditioning {cond:.2e} < {min_conditioning:.0e}): "
           "motion along the baseline or too small" if degenerate else "")
    if not degenerate and len(lengths) and min(lengths.values()) < -0.25 * rops.baseline:
        degenerate, msg = True, f"ray intersection behind a camera (lengths {lengths})"
    R_1_4 = R_1_3 @ rops.R_1_2
    return InitialEops(R_1_3, R_1_4, c3, c3 + R_1_3 @ rops.t_1_2, lengths, cond, degenerate, msg)
