"""Shared pieces of the stereo PnP estimators: configuration, PnP with RANSAC + LM refinement, and the
motion-prior consensus between several rigid motions.

Poses: ``T_o_c0`` left camera in the frame ``o`` of the first left camera; PnP returns ``T_c0_o``
(OpenCV's rvec/tvec map object points into the camera), inverted at the boundary in :func:`solve_pnp`.

Consensus (our extension; seed 003 takes RANSAC's largest consensus): in traffic a car driving ahead at
the vehicle's speed is a large rigid cluster of long-lived tracks whose landmarks say "the camera stands
still". On ``urban-dynamic`` it holds 75-95 % of the PnP inliers on a quarter of the frames, and those
frames carry 93 % of klt-pnp's end error (docs/estimators.md, "Moving objects"). With
``consensus="prior"`` :func:`solve_pnp` fits up to ``max_models`` rigid motions in turn (each RANSAC on
the points the earlier models left over) and, among those with at least
``max(min_pnp_inliers, min_model_fraction * N)`` inliers, keeps the one whose camera position is nearest
the motion prior (constant velocity); LM started at the prior adds one more candidate (RANSAC's models can
mix the world with a slow car). When another candidate holds mostly other points, the chosen motion is
refitted on the points it explains better than the others; a candidate with fewer such points of its own than a
motion needs is not a motion and leaves the choice. Without a prior it is RANSAC's answer.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from rigs.geometry import inv_T, make_T, transform_points
from rigs.geometry.pinhole import project
from rigs.typed_config import check_fields, from_mapping, knob
from vo.errors import EstimatorError
from rigs.image import to_gray  # noqa: F401  (re-exported: the estimators' grey conversion)

PNP_METHODS = {"iterative": cv2.SOLVEPNP_ITERATIVE, "epnp": cv2.SOLVEPNP_EPNP}
CONSENSUS = ("prior", "largest")


@dataclass(frozen=True)
class PnpConfig:
    """``method`` RANSAC minimal solver (iterative | epnp); ``ransac_reproj_px`` inlier threshold on
    undistorted pixels; ``ransac_iters``, ``confidence``; ``min_features`` fewer tracked landmarks ->
    status few_features; ``min_pnp_inliers`` fewer inliers -> lost; ``min_init_landmarks`` stereo
    landmarks needed to (re)initialise; ``max_depth`` m and ``max_triangulation_px`` triangulation checks;
    ``max_step_m`` largest believable camera motion between frames (m) before the frame is declared lost;
    ``consensus`` "prior" (several rigid motions, the one nearest the motion prior; module docstring) |
    "largest" (RANSAC's largest consensus, seed 003); ``max_models`` motions fitted in turn;
    ``min_model_fraction`` a motion competes with at least this fraction of the landmarks as inliers;
    ``separation_px`` two motions are different when at least that many landmarks of one lie more than
    this far off the other's reprojection (:func:`separated`); ``near_baselines``, ``min_near_inliers``,
    ``calib_tolerance_px``: the close/far split of :mod:`vo.estimators.near_far` (``near_baselines`` 0, the
    default, turns it off: ``klt-pnp`` corrects the disparity offset it guarded against at its cause,
    :mod:`vo.estimators.disparity_offset`; 40 is ORB-SLAM2's value); ``predict_tracks`` (``klt-pnp``) starts the
    temporal LK at the landmarks' constant-velocity prediction (:mod:`vo.estimators.track_prediction`; not in
    seed 003; False: seed 003's zero flow)."""

    method: Literal[tuple(PNP_METHODS)] = "epnp"
    ransac_reproj_px: float = knob(2.0, gt=0)
    ransac_iters: int = knob(200, ge=1)
    confidence: float = knob(0.999, gt=0, lt=1)
    min_features: int = knob(15, ge=6)
    min_pnp_inliers: int = knob(10, ge=4)
    min_init_landmarks: int = knob(20, ge=6)
    max_depth: float = knob(80.0, gt=0)
    max_triangulation_px: float = knob(1.0, gt=0)
    max_step_m: float = knob(5.0, gt=0)
    consensus: Literal[CONSENSUS] = "prior"
    max_models: int = knob(3, ge=1)
    min_model_fraction: float = knob(0.1, ge=0, le=1)
    separation_px: float = knob(4.0, gt=0)
    near_baselines: float = knob(0.0, ge=0)
    min_near_inliers: int = knob(10, ge=6)
    calib_tolerance_px: float = knob(0.5, ge=0)
    predict_tracks: bool = True

    def __post_init__(self):
        check_fields(self, EstimatorError, "pnp.")

    @classmethod
    def from_option(cls, value, where: str = "pnp_config") -> "PnpConfig":
        """An estimator's ``pnp_config`` option: ``None`` (defaults), a :class:`PnpConfig`, or a mapping of
        its fields (``--opt 'pnp_config={consensus: largest}'``)."""
        if isinstance(value, cls):
            return value
        return from_mapping(cls, value, EstimatorError, where)


def _fit(obj: np.ndarray, img: np.ndarray, K: np.ndarray, sel: np.ndarray, config: PnpConfig):
    """RANSAC (``config.method``) + LM on the points ``sel`` -> ``T_c0_o`` or None."""
    if sel.sum() < max(6, config.min_pnp_inliers):
        return None
    try:
        ok, rvec, tvec, idx = cv2.solvePnPRansac(obj[sel], img[sel], K, None, iterationsCount=config.ransac_iters,
                                                 reprojectionError=config.ransac_reproj_px,
                                                 confidence=config.confidence, flags=PNP_METHODS[config.method])
    except cv2.error:
        return None
    if not ok or idx is None or len(idx) < config.min_pnp_inliers:
        return None
    inl = np.flatnonzero(sel)[idx.reshape(-1)]
    try:
        rvec, tvec = cv2.solvePnPRefineLM(obj[inl], img[inl], K, None, rvec, tvec)
    except cv2.error:
        pass
    T_c0_o = make_T(cv2.Rodrigues(rvec)[0], tvec.reshape(3))
    return T_c0_o if np.all(np.isfinite(T_c0_o)) else None


def reprojection_errors(T_c0_o: np.ndarray, p_o: np.ndarray, x: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(N,) reprojection error in px (inf behind the camera)."""
    p_c = transform_points(T_c0_o, p_o)
    err = np.full(len(p_o), np.inf)
    front = p_c[:, 2] > 0
    err[front] = np.linalg.norm(project(p_c[front], K) - x[front], axis=1)
    return err


def _inliers(T_c0_o: np.ndarray, p_o: np.ndarray, x: np.ndarray, K: np.ndarray, thr: float) -> np.ndarray:
    """(N,) bool: in front of the camera and reprojected within ``thr`` px."""
    return reprojection_errors(T_c0_o, p_o, x, K) < thr


def _own_points(chosen: tuple, others: list, p_o, x, K) -> np.ndarray:
    """(N,) bool: the inliers of the chosen motion ``(T_c0_o, inliers)`` that it explains better than every other
    candidate motion of ``others`` explaining them."""
    T, inl = chosen
    err = reprojection_errors(T, p_o, x, K)
    own = inl.copy()
    for T_other, inl_other in others:
        own &= ~(inl_other & (reprojection_errors(T_other, p_o, x, K) < err))
    return own


def _exclusive_refit(chosen: tuple, own: np.ndarray, p_o, x, K, config: PnpConfig) -> tuple:
    """Refit the chosen motion on ``own`` (:func:`_own_points`), the points it explains better than every other
    candidate: points of a moving car that also fall inside the chosen motion's gate (near the focus of
    expansion) would otherwise pull the LM fit. Returns ``(T_c0_o, inliers)``; the chosen fit when too few
    points remain."""
    T = chosen[0]
    if own.sum() < max(6, config.min_pnp_inliers):
        return chosen
    obj = np.ascontiguousarray(p_o[own], dtype=np.float64).reshape(-1, 1, 3)
    img = np.ascontiguousarray(x[own], dtype=np.float64).reshape(-1, 1, 2)
    rvec, tvec = cv2.Rodrigues(T[:3, :3])[0], T[:3, 3].reshape(3, 1).copy()
    try:
        rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, None, rvec, tvec)
    except cv2.error:
        return chosen
    T_new = make_T(cv2.Rodrigues(rvec)[0], tvec.reshape(3))
    if not np.all(np.isfinite(T_new)):
        return chosen
    return T_new, own & _inliers(T_new, p_o, x, K, config.ransac_reproj_px)


def candidate_motions(p_o: np.ndarray, x_undist: np.ndarray, K: np.ndarray, config: PnpConfig) -> list:
    """Up to ``config.max_models`` rigid motions ``(T_c0_o, inliers)``, each fitted on the points the
    earlier ones left over (inliers counted over all points); the first is RANSAC's largest consensus.
    Only motions with at least ``max(min_pnp_inliers, min_model_fraction * N)`` inliers after the first."""
    n = len(p_o)
    obj = np.ascontiguousarray(p_o, dtype=np.float64).reshape(-1, 1, 3)
    img = np.ascontiguousarray(x_undist, dtype=np.float64).reshape(-1, 1, 2)
    x = img.reshape(-1, 2)
    need = max(config.min_pnp_inliers, config.min_model_fraction * n)
    models, left = [], np.ones(n, bool)
    while len(models) < config.max_models and left.sum() >= (need if models else 0):
        T = _fit(obj, img, K, left, config)
        if T is None:
            break
        inl = _inliers(T, p_o, x, K, config.ransac_reproj_px)
        if not (inl & left).any() or (models and inl.sum() < need):
            break
        models.append((T, inl))
        left &= ~inl
    return models


def _prior_seeded(T_c0_o: np.ndarray, p_o, x, K, config: PnpConfig, need: float):
    """The motion LM converges to from the prior pose (inliers at twice, then once the gate) -> ``(T_c0_o,
    inliers)`` or None: the static world's motion even when RANSAC's models mix it with a slow car."""
    for thr in (2.0 * config.ransac_reproj_px, config.ransac_reproj_px):
        inl = _inliers(T_c0_o, p_o, x, K, thr)
        if inl.sum() < max(need, 6):
            return None
        obj = np.ascontiguousarray(p_o[inl], dtype=np.float64).reshape(-1, 1, 3)
        img = np.ascontiguousarray(x[inl], dtype=np.float64).reshape(-1, 1, 2)
        try:
            rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, None, cv2.Rodrigues(T_c0_o[:3, :3])[0],
                                              T_c0_o[:3, 3].reshape(3, 1).copy())
        except cv2.error:
            return None
        T_c0_o = make_T(cv2.Rodrigues(rvec)[0], tvec.reshape(3))
        if not np.all(np.isfinite(T_c0_o)):
            return None
    inl = _inliers(T_c0_o, p_o, x, K, config.ransac_reproj_px)
    return (T_c0_o, inl) if inl.sum() >= need else None


def separated(a: tuple, b: tuple, p_o, x, K, config: PnpConfig, need: float) -> bool:
    """Whether candidate motions ``a`` and ``b`` (``(T_c0_o, inliers)``) are different rigid motions: at least
    ``need`` inliers of one lie more than ``config.separation_px`` off the other's reprojection. Shared
    inliers say nothing (far points fit any small translation, so a departing or crossing car's fit and the
    standing-still one share them). The 4 px default (twice the inlier gate): under the true motion the
    static landmarks lie beyond 4 px in 1.5 % (``urban-static``) / 3.0 % (``urban-dynamic`` seed 0) of the
    cases (keyframe triangulation error), far below the 10 % a motion needs, the moving-actor landmarks in
    75 % (median 9.7 px). On the 997 urban-static frames 2 / 4 / 8 px find two "motions" on 194 / 76 / 14
    frames (the chosen fit is then no worse than RANSAC's: summed step error 13.6 m at 4 px, 14.3 m with
    inlier overlap); 8 px missed a distant car 0.6 m off the static motion (3.5 px) on a slow
    ``urban-dynamic`` seed 1 frame."""
    (T_a, inl_a), (T_b, inl_b) = a, b
    thr = config.separation_px
    return bool(np.sum(inl_b & (reprojection_errors(T_a, p_o, x, K) > thr)) >= need
                or np.sum(inl_a & (reprojection_errors(T_b, p_o, x, K) > thr)) >= need)


def choose_motion(p_o: np.ndarray, x_undist: np.ndarray, K: np.ndarray, config: PnpConfig,
                  T_o_c0_prior: np.ndarray):
    """The candidate motion (:func:`candidate_motions`, plus the one LM reaches from the prior) whose camera
    position is nearest the prior's -> ``(T_c0_o, inliers, competing)`` or None; ``competing`` when another
    candidate is a different rigid motion (:func:`separated`), and then the chosen one is refitted on the
    points it explains better than those (:func:`_own_points`). A candidate needs as many points of its own as a
    motion needs inliers (``max(min_pnp_inliers, min_model_fraction * N)``): one whose points the other motions
    explain better is a refit of theirs (on a short baseline, the far points' leftovers of RANSAC's fit land a
    few mm from the prior) and leaves the choice, which is made again among the others. Without competition the
    first (RANSAC's) candidate: picking the fit nearest the prior among fits of one motion would pull every frame
    towards constant velocity (urban-kitti klt-pnp 0.70 -> 0.99 % drift)."""
    p_o, x = np.asarray(p_o, float), np.asarray(x_undist, float)
    need = max(config.min_pnp_inliers, config.min_model_fraction * len(p_o))
    models = [m for m in candidate_motions(p_o, x, K, config) if m[1].sum() >= config.min_pnp_inliers]
    seeded = _prior_seeded(inv_T(np.asarray(T_o_c0_prior, float)), p_o, x, K, config, need)
    models += [seeded] if seeded is not None else []
    if not models:
        return None
    c_prior = np.asarray(T_o_c0_prior, float)[:3, 3]
    live = list(models)             # the candidates that are motions of their own
    while live:
        i = int(np.argmin([np.linalg.norm(inv_T(T)[:3, 3] - c_prior) for T, _ in live]))
        others = [m for j, m in enumerate(live) if j != i and separated(live[i], m, p_o, x, K, config, need)]
        if not others:              # one rigid motion: RANSAC's fit, exactly as without a prior
            break
        own = _own_points(live[i], others, p_o, x, K)
        if own.sum() >= need:
            return (*_exclusive_refit(live[i], own, p_o, x, K, config), True)
        del live[i]                 # the other motions explain its points: not a motion, out of the choice
    return (*models[0], False)


def solve_pnp(p_o: np.ndarray, x_undist: np.ndarray, K: np.ndarray, config: PnpConfig,
              T_o_c0_prior: np.ndarray | None = None) -> tuple:
    """3-D landmarks ``p_o`` (N,3) seen at undistorted pixels ``x_undist`` (N,2) -> ``(T_o_c0 | None,
    inliers (N,) bool)``.

    ``cv2.solvePnPRansac`` (minimal solver ``config.method``) then ``cv2.solvePnPRefineLM`` on the inliers;
    with ``config.consensus == "prior"`` and a prior pose ``T_o_c0_prior``, :func:`choose_motion`.
    """
    n = len(p_o)
    if n < max(6, config.min_pnp_inliers):
        return None, np.zeros(n, bool)
    if config.consensus == "prior" and T_o_c0_prior is not None:
        chosen = choose_motion(p_o, x_undist, K, config, T_o_c0_prior)
        if chosen is None or chosen[1].sum() < config.min_pnp_inliers:
            return None, np.zeros(n, bool)
        return inv_T(chosen[0]), chosen[1]
    models = candidate_motions(p_o, x_undist, K, _one_model(config))
    if not models or models[0][1].sum() < config.min_pnp_inliers:
        return None, np.zeros(n, bool)
    return inv_T(models[0][0]), models[0][1]


def _one_model(config: PnpConfig) -> PnpConfig:
    return config if config.max_models == 1 else dataclasses.replace(config, max_models=1)
