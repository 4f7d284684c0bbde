"""Seed 000's two-step ROP network adjustment (section 2.4, eqs. 1-3), O frame = C_1.

Step 1 (eq. 1), rotations: unknowns the 18 elements of ``R_1_3`` (= R_3^O) and ``R_1_4`` (= R_4^O),
row-major. Observations: the 9 elements of each of ``R_2_4, R_3_4, R_1_3, R_1_4, R_2_3`` (45) and
the 6 inner constraints ``R^T R = I`` of each unknown rotation (3 unit columns, 3 orthogonal column
pairs; 12), 57 in all. Models: ``R_1_3 = R3``, ``R_1_4 = R4``, ``R_2_3 = R_1_2^T R3``,
``R_2_4 = R_1_2^T R4``, ``R_3_4 = R3^T R4`` (R_1^O = I, R_2^O = R_1_2 calibrated). Gauss-Newton on
the whitened system. Weights: inlier count ratio ``n / mean(n)`` for the four estimated ROPs
(``RopSet.weighting="sampson"``: inverse Sampson variances instead, our extension);
``hard_weight`` (1e8) for the calibrated ``R_3_4`` and the 12 constraints. The paper does not say
how the 18 adjusted elements become rotations: we re-orthonormalise by SVD for output (the change
is ~1e-8 because the constraints are nearly hard).

Step 2 (eqs. 2-3), translations: unknowns the origins ``r3 = t_1_3``, ``r4 = t_1_4`` (6).
Observations: the unit directions ``rhat_2_4, rhat_3_4, rhat_1_3, rhat_1_4, rhat_2_3`` (15), each in
its own frame i: ``rhat_i_j = R_1_i^T (r_j - r_i) / lambda_i_j`` with the step-1 rotations as
fixed coefficients. Scales are recomputed from the current positions every iteration (eq. 3;
the paper prints ``sqrt((r_a - r_b)^2)``, which means the Euclidean norm ``|r_a - r_b|``); only
``lambda_3_4`` = the calibrated baseline is fixed, which with the hard-weighted ``rhat_3_4`` gives
the scale. Jacobian: ``"paper"`` treats ``1/lambda`` as a constant coefficient (the linear form of
eq. 2, a fixed-point iteration); ``"gauss_newton"`` (default) also differentiates the
normalisation, ``(I - u u^T) R_1_i^T / lambda``. Both have the same solution to first order in
the noise; the Gauss-Newton one converges in a few iterations and is the one used for the
covariance in both modes (the component of a unit vector along itself carries no information).

Covariances (rotation vectors with the left perturbation ``R = exp(dphi) R_hat``, positions in m):
``Q = (A^T W A)^-1`` at convergence. A-priori: a unit-weight ROP has angular sigma ``sigma_rot_rad``
per axis (then each of its 9 rotation elements has sigma ``sqrt(2) sigma_rot_rad`` in the tangent
directions) and ``sigma_dir_rad`` per tangent axis of its direction (element sigma ``sigma_dir_rad``);
``cov = sigma_el^2 Q``. A-posteriori: ``sigma0^2 = v^T W v / r`` replaces ``sigma_el^2``, with the
redundancy counted in degrees of freedom, the hard constraints removing unknowns rather than adding
observations: step 1 ``r = 3 n_rop - 3`` (each rotation has 3 dof; 6 free unknowns minus the
3 fixed by ``R_3_4``), step 2 ``r = 2 n_rop - 3`` (a direction has 2 dof). Rotation errors of step
1 reach step 2 only through ``R_1_3`` in the ``rhat_3_4`` model; we propagate them to first order
(``d r / d phi_3``) instead of assuming the two steps independent, and treat the rotation and the
direction of one ROP as independent (they come from one essential matrix; this is approximate).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from vo.errors import EstimatorError
from rigs.geometry import make_T, rotation_angle, skew
from vo.rop.initial_eops import InitialEops, initial_eops, project_to_so3
from vo.rop.propagation import propagated_cov
from vo.rop.ropset import RopSet

JACOBIANS = ("gauss_newton", "paper")


@dataclass(frozen=True)
class AdjustmentConfig:
    """``hard_weight`` relative weight of calibrated ROPs and constraints; ``max_iter``, ``tol``
    (max step: 1e-12 of a rotation element / metre); a-priori unit-weight sigmas (rad) or None."""

    hard_weight: float = 1e8
    max_iter: int = 100
    tol: float = 1e-12
    translation_jacobian: str = "gauss_newton"
    sigma_rot_rad: Optional[float] = None
    sigma_dir_rad: Optional[float] = None

    def __post_init__(self):
        if self.translation_jacobian not in JACOBIANS:
            raise EstimatorError(f"AdjustmentConfig.translation_jacobian: {self.translation_jacobian!r}; "
                                 f"valid: {', '.join(JACOBIANS)}")
        for f in ("hard_weight", "tol", "sigma_rot_rad", "sigma_dir_rad"):
            v = getattr(self, f)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise EstimatorError(f"AdjustmentConfig.{f}: must be a positive finite number, got {v!r}")
        if int(self.max_iter) < 1:
            raise EstimatorError(f"AdjustmentConfig.max_iter: must be >= 1, got {self.max_iter!r}")


@dataclass(frozen=True)
class StepResult:
    """One adjustment step: ``x`` unknowns, ``Q`` cofactor (rotvec / metres), ``vtwv``, redundancy."""

    x: np.ndarray
    Q: np.ndarray
    vtwv: float
    redundancy: int
    iterations: int
    converged: bool
    conditioning: float
    extra: dict = field(default_factory=dict)

    @property
    def sigma0_sq(self) -> Optional[float]:
        """Estimated unit-weight variance ``v^T W v / r`` (None when r <= 0)."""
        return self.vtwv / self.redundancy if self.redundancy > 0 else None


@dataclass(frozen=True)
class RopAdjustmentResult:
    """Adjusted ``T_c1_c3``, ``T_c1_c4`` (4,4) and covariances of ``[rotvec, position]`` of T_c1_c3.

    ``cov`` (6,6) = ``cov_apriori`` when a-priori sigmas were configured, else ``cov_apost``;
    ``cov_rot``/``cov_pos`` are its (3,3) blocks; ``cov_full`` (12,12) of
    ``[phi3, phi4, r3, r4]`` in the same choice. ``sigma0_sq_rot`` is in (rotation element)^2,
    ``sigma0_sq_dir`` in (unit-vector element)^2; ``variance_factors`` = a-posteriori / a-priori.
    ``residuals``: pair -> (rotation residual angle, direction residual angle) in rad.
    """

    T_c1_c3: np.ndarray
    T_c1_c4: np.ndarray
    cov: np.ndarray
    cov_rot: np.ndarray
    cov_pos: np.ndarray
    cov_full: np.ndarray
    cov_apost: Optional[np.ndarray]
    cov_apriori: Optional[np.ndarray]
    sigma0_sq_rot: Optional[float]
    sigma0_sq_dir: Optional[float]
    variance_factors: Optional[tuple]
    iterations: tuple
    converged: bool
    residuals: dict
    initial: InitialEops
    degenerate: bool
    message: str = ""
    cov_propagated: Optional[np.ndarray] = None   # (6,6) from the ROPs' own cov6 (vo.rop.propagation)


def _whitened_solve(J: np.ndarray, e: np.ndarray, w: np.ndarray):
    """Weighted LS step ``argmin |sqrt(w) (J dx - e)|``; returns dx, QR factors of sqrt(w) J."""
    sw = np.sqrt(w)
    Qm, Rm = np.linalg.qr(sw[:, None] * J)
    dx = np.linalg.lstsq(Rm, Qm.T @ (sw * e), rcond=None)[0]
    return dx, Qm, Rm


def _cofactor(Rm: np.ndarray) -> tuple[np.ndarray, float]:
    """``(A^T W A)^-1`` from the R factor, and the conditioning ``s_min / s_max`` of ``sqrt(W) A``."""
    s = np.linalg.svd(Rm, compute_uv=False)
    Rinv = np.linalg.pinv(Rm)
    return Rinv @ Rinv.T, float(s[-1] / s[0])


# ----------------------------------------------------------------------------- step 1: rotations
def _transpose_perm() -> np.ndarray:
    """(9,9) P with ``vec(X^T) = P vec(X)`` (row-major vec)."""
    P = np.zeros((9, 9))
    for a in range(3):
        for b in range(3):
            P[3 * b + a, 3 * a + b] = 1.0
    return P


_P9 = _transpose_perm()


def _orthonormality(R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """6 inner constraints of ``R`` (values g, Jacobian (6,9) wrt row-major vec(R))."""
    idx = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]
    g, J = np.zeros(6), np.zeros((6, 9))
    for k, (a, b) in enumerate(idx):
        g[k] = R[:, a] @ R[:, b] - (1.0 if a == b else 0.0)
        for m in range(3):
            J[k, 3 * m + b] += R[m, a]
            J[k, 3 * m + a] += R[m, b]
    return g, J


def _rotation_system(x: np.ndarray, rops: RopSet, weights: dict, hard: float):
    """Residuals ``e = l - f(x)`` (n,), Jacobian (n,18), weights (n,), soft-row count per pair."""
    R3, R4 = x[:9].reshape(3, 3), x[9:].reshape(3, 3)
    R12 = rops.R_1_2
    I3, Z = np.eye(3), np.zeros((9, 9))
    K = np.kron(R12.T, I3)
    model = {"13": (R3, np.eye(9), Z), "14": (R4, Z, np.eye(9)),
             "23": (R12.T @ R3, K, Z), "24": (R12.T @ R4, Z, K)}
    es, Js, ws = [], [], []
    for p, w in weights.items():
        f, J3, J4 = model[p]
        es.append((rops.rops[p].R_i_j - f).ravel())
        Js.append(np.hstack([J3, J4]))
        ws.append(np.full(9, w))
    es.append((rops.R_1_2 - R3.T @ R4).ravel())                       # calibrated R_3_4 = R_1_2
    Js.append(np.hstack([np.kron(I3, R4.T) @ _P9, np.kron(R3.T, I3)]))
    ws.append(np.full(9, hard))
    for k, R in enumerate((R3, R4)):
        g, Jg = _orthonormality(R)
        es.append(-g)
        Js.append(np.hstack([Jg, np.zeros((6, 9))]) if k == 0 else np.hstack([np.zeros((6, 9)), Jg]))
        ws.append(np.full(6, hard))
    return np.concatenate(es), np.vstack(Js), np.concatenate(ws)


def _rotvec_map(R: np.ndarray) -> np.ndarray:
    """(3,9) pseudo-inverse of ``dphi -> vec(skew(dphi) R)`` (left perturbation): ``0.5 J^T``."""
    J = np.stack([(skew(e) @ R).ravel() for e in np.eye(3)], axis=1)
    return 0.5 * J.T


def adjust_rotations(rops: RopSet, R_1_3_init: np.ndarray, cfg: AdjustmentConfig) -> StepResult:
    """Step 1. ``x`` = [R_1_3, R_1_4] (2,3,3) re-orthonormalised; ``Q`` (6,6) of ``[phi3, phi4]``."""
    weights = rops.weights("rot")
    x = np.concatenate([R_1_3_init.ravel(), (R_1_3_init @ rops.R_1_2).ravel()])
    converged, it = False, 0
    for it in range(1, int(cfg.max_iter) + 1):
        e, J, w = _rotation_system(x, rops, weights, cfg.hard_weight)
        dx, _, _ = _whitened_solve(J, e, w)
        x = x + dx
        if np.max(np.abs(dx)) < cfg.tol:
            converged = True
            break
    e, J, w = _rotation_system(x, rops, weights, cfg.hard_weight)
    _, Qm, Rm = _whitened_solve(J, e, w)
    Q18, cond = _cofactor(Rm)
    R3, R4 = project_to_so3(x[:9].reshape(3, 3)), project_to_so3(x[9:].reshape(3, 3))
    G = np.zeros((6, 18))
    G[:3, :9], G[3:, 9:] = _rotvec_map(R3), _rotvec_map(R4)
    n_soft = len(weights)
    vtwv = float(np.sum(w[:9 * n_soft] * e[:9 * n_soft] ** 2))
    gain = G @ np.linalg.pinv(Rm) @ (Qm.T * np.sqrt(w))[:, :9 * n_soft]      # d[phi3, phi4] / d(soft rows)
    return StepResult(np.stack([R3, R4]), G @ Q18 @ G.T, vtwv, 3 * n_soft - 3, it, converged, cond,
                      {"gain": gain, "pairs": tuple(weights)})


# -------------------------------------------------------------------------- step 2: translations
def _translation_system(x: np.ndarray, rops: RopSet, R_1_3: np.ndarray, weights: dict,
                        hard: float, jacobian: str):
    """Residuals (n,), Jacobian (n,6), weights (n,), d f / d phi3 (n,3) for ``x = [r3, r4]``."""
    r = {1: np.zeros(3), 2: rops.t_1_2, 3: x[:3], 4: x[3:]}
    R = {1: np.eye(3), 2: rops.R_1_2}
    es, Js, ws = [], [], []
    for p, w in weights.items():
        i, j = int(p[0]), int(p[1])
        d = R[i].T @ (r[j] - r[i])
        lam = np.linalg.norm(d)                                   # eq. 3: lambda_i_j = |r_j - r_i|
        u = d / lam
        A = R[i].T / lam if jacobian == "paper" else (np.eye(3) - np.outer(u, u)) @ R[i].T / lam
        Jp = np.zeros((3, 6))
        Jp[:, 3 * (j - 3):3 * (j - 2)] = A
        es.append(rops.rops[p].rhat_i_j - u)
        Js.append(Jp)
        ws.append(np.full(3, w))
    lam34 = rops.baseline                                         # the only fixed scale
    d34 = x[3:] - x[:3]
    es.append(rops.t_1_2 / lam34 - R_1_3.T @ d34 / lam34)         # calibrated rhat_3_4
    Js.append(np.hstack([-R_1_3.T, R_1_3.T]) / lam34)
    ws.append(np.full(3, hard))
    F = np.zeros((3 * len(weights) + 3, 3))
    F[-3:] = R_1_3.T @ skew(d34) / lam34
    return np.concatenate(es), np.vstack(Js), np.concatenate(ws), F


def adjust_translations(rops: RopSet, R_1_3: np.ndarray, r3: np.ndarray, r4: np.ndarray,
                        cfg: AdjustmentConfig) -> StepResult:
    """Step 2. ``x`` = [r3, r4] (6,); ``Q`` (6,6); ``extra["dx_dphi3"]`` (6,3) coupling to step 1."""
    weights = rops.weights("dir")
    x = np.concatenate([r3, r4]).astype(float)
    converged, it = False, 0
    for it in range(1, int(cfg.max_iter) + 1):
        e, J, w, _ = _translation_system(x, rops, R_1_3, weights, cfg.hard_weight, cfg.translation_jacobian)
        dx, _, _ = _whitened_solve(J, e, w)
        x = x + dx
        if not np.all(np.isfinite(x)):
            break
        if np.max(np.abs(dx)) < cfg.tol:
            converged = True
            break
    e, J, w, F = _translation_system(x, rops, R_1_3, weights, cfg.hard_weight, "gauss_newton")
    _, Qm, Rm = _whitened_solve(J, e, w)
    Q, cond = _cofactor(Rm)
    K = np.linalg.pinv(Rm) @ (Qm.T * np.sqrt(w))                                 # dx / d(residual rows)
    dx_dphi3 = -K @ F
    n_soft = len(weights)
    vtwv = float(np.sum(w[:3 * n_soft] * e[:3 * n_soft] ** 2))
    return StepResult(x, Q, vtwv, 2 * n_soft - 3, it, converged, cond,
                      {"dx_dphi3": dx_dphi3, "gain": K[:, :3 * n_soft]})


# ------------------------------------------------------------------------------------- together
def _full_cov(rot: StepResult, tra: StepResult, s_rot_sq: float, s_dir_sq: float) -> np.ndarray:
    """(12,12) covariance of ``[phi3, phi4, r3, r4]`` with first-order step-1 -> step-2 coupling."""
    S_phi = s_rot_sq * rot.Q
    G = np.zeros((6, 6))
    G[:, :3] = tra.extra["dx_dphi3"]
    C = np.zeros((12, 12))
    C[:6, :6] = S_phi
    C[6:, :6] = G @ S_phi
    C[:6, 6:] = C[6:, :6].T
    C[6:, 6:] = s_dir_sq * tra.Q + G @ S_phi @ G.T
    return 0.5 * (C + C.T)


_T3 = np.r_[0:3, 6:9]   # indices of [phi3, r3] in the full state


def _covariances(rot: StepResult, tra: StepResult, cfg: AdjustmentConfig):
    """-> (cov_full, cov_apost_full or None, cov_apriori_full or None, variance factors or None)."""
    apost = (_full_cov(rot, tra, rot.sigma0_sq, tra.sigma0_sq)
             if rot.sigma0_sq is not None and tra.sigma0_sq is not None else None)
    apriori, factors = None, None
    if cfg.sigma_rot_rad is not None and cfg.sigma_dir_rad is not None:
        el_rot, el_dir = 2.0 * cfg.sigma_rot_rad ** 2, cfg.sigma_dir_rad ** 2
        apriori = _full_cov(rot, tra, el_rot, el_dir)
        if apost is not None:
            factors = (rot.sigma0_sq / el_rot, tra.sigma0_sq / el_dir)
    chosen = apriori if apriori is not None else apost
    if chosen is None:                       # no redundancy, no a-priori sigmas: unit-weight cofactor
        chosen = _full_cov(rot, tra, 1.0, 1.0)
    return chosen, apost, apriori, factors


def _residual_angles(rops: RopSet, R3: np.ndarray, r3: np.ndarray, r4: np.ndarray) -> dict:
    """pair -> (rotation residual angle, direction residual angle) in rad at the solution."""
    R = {1: np.eye(3), 2: rops.R_1_2, 3: R3, 4: R3 @ rops.R_1_2}
    r = {1: np.zeros(3), 2: rops.t_1_2, 3: r3, 4: r4}
    out = {}
    for p in rops.ok_pairs:
        i, j = int(p[0]), int(p[1])
        m = rops.rops[p]
        d = R[i].T @ (r[j] - r[i])
        c = np.clip(m.rhat_i_j @ d / np.linalg.norm(d), -1.0, 1.0)
        out[p] = (float(rotation_angle(m.R_i_j.T @ R[i].T @ R[j])), float(np.arccos(c)))
    return out


def adjust_rops(rops: RopSet, initial: Optional[InitialEops] = None,
                config: AdjustmentConfig = AdjustmentConfig()) -> RopAdjustmentResult:
    """Initial EOPs (unless given) then both adjustment steps -> :class:`RopAdjustmentResult`.

    On a degenerate configuration (no usable ROP, parallel rays, non-finite result) the result
    carries ``degenerate=True`` and the initial EOPs (always finite)."""
    init = initial if initial is not None else initial_eops(rops)
    if len(rops.ok_pairs) < 2:
        return _degenerate(init, f"{len(rops.ok_pairs)} usable ROP(s) < 2")
    if init.degenerate:
        return _degenerate(init, init.message)
    rot = adjust_rotations(rops, init.R_1_3, config)
    R3, R4 = rot.x
    tra = adjust_translations(rops, R3, init.t_1_3, init.t_1_4, config)
    r3, r4 = tra.x[:3], tra.x[3:]
    if not (np.all(np.isfinite(tra.x)) and np.all(np.isfinite(rot.x))):
        return _degenerate(init, "adjustment diverged (non-finite)")
    chosen, apost, apriori, factors = _covariances(rot, tra, config)
    pick = (lambda C: None if C is None else C[np.ix_(_T3, _T3)])
    cov = pick(chosen)
    prop = propagated_cov(rops, rot.extra["pairs"], rot.extra["gain"], tra.extra["gain"], tra.extra["dx_dphi3"])
    degenerate = init.degenerate or tra.conditioning < 1e-9 or not np.all(np.isfinite(cov))
    msg = init.message or ("" if rot.converged and tra.converged else
                           f"not converged in {config.max_iter} iterations")
    return RopAdjustmentResult(
        make_T(R3, r3), make_T(R4, r4), cov, cov[:3, :3], cov[3:, 3:], chosen, pick(apost), pick(apriori),
        rot.sigma0_sq, tra.sigma0_sq, factors, (rot.iterations, tra.iterations),
        rot.converged and tra.converged, _residual_angles(rops, R3, r3, r4), init, degenerate, msg, pick(prop))


def _degenerate(init: InitialEops, message: str) -> RopAdjustmentResult:
    """A finite, flagged result holding the initial EOPs and a large (1 rad, 1 m) covariance."""
    big = np.eye(12)
    return RopAdjustmentResult(init.T_c1_c3, init.T_c1_c4, big[np.ix_(_T3, _T3)], np.eye(3), np.eye(3), big,
                               None, None, None, None, None, (0, 0), False, {}, init, True, message)
