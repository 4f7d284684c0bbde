"""Covariance of the ``rop`` pose: the :class:`UncertaintyModel` interface and the first-order default.

The estimator (:mod:`vo.rop.estimator`) computes poses; an uncertainty model turns every solved frame
(a :class:`Step`) into the (6,6) covariance of ``[rotvec, position]`` of ``T_o_c0`` (left perturbation,
as ``FrameResult.cov``). Models shipped: :class:`PropagatedCovariance` (default) and
:class:`vo.rop.chain_bootstrap.ChainBootstrap`; :func:`vo.rop.cov_models.make_uncertainty` picks one from
``RopConfig.cov``. Any object with the two methods below can be passed as
``RopEstimator(rig, config, uncertainty=model)`` (docs/studies/ plugs its study models in that way).

First order (``cov="propagated"``, our extension; seed 000 gives no precision model): each ROP's
Sampson covariance propagated through the adjustment's converged gains (:mod:`vo.rop.propagation`)
is the step covariance ``cov_step`` of ``T_kf_c``; it is chained onto the keyframe's covariance by
:func:`propagate_cov`, keyframe steps treated as independent (consecutive steps share tracks, so
this is approximate; :mod:`vo.rop.chain_bootstrap` keeps their correlation).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Protocol

import numpy as np

from rigs.geometry import skew


@dataclass(frozen=True)
class Step:
    """One frame solved against its keyframe.

    ``t_ns``; ``T_o_kf`` (4,4) and ``cov_kf`` (6,6) the keyframe pose and its covariance; ``T_kf_c``
    (4,4) the adjusted step to the current left camera and ``cov_step`` (6,6) its first-order
    covariance; ``keyframe`` the current frame becomes the next keyframe (its step chains);
    ``ropset`` the four ROPs (None for a rotation-only epoch) and ``adjustment`` the
    :class:`~vo.rop.adjustment.RopAdjustmentResult` (None likewise); ``pairs`` pair -> normalized
    matches ``(x_i, x_j)``; ``tracks`` the :class:`~vo.rop.tracks.FourView` (KLT front-end, else None);
    ``images`` (keyframe left, keyframe right, current left, current right) grey images."""

    t_ns: int
    T_o_kf: np.ndarray
    cov_kf: np.ndarray
    T_kf_c: np.ndarray
    cov_step: np.ndarray
    keyframe: bool
    ropset: Optional[object] = None
    adjustment: Optional[object] = None
    pairs: Optional[dict] = None
    tracks: Optional[object] = None
    images: tuple = ()

    @property
    def T_o_c(self) -> np.ndarray:
        return self.T_o_kf @ self.T_kf_c


class UncertaintyModel(Protocol):
    """What the estimator calls: :meth:`on_step` once per solved frame (in frame order), :meth:`reset`
    after a failed frame (the pose was coasted and the frame becomes a fresh keyframe)."""

    def on_step(self, step: Step) -> np.ndarray:
        """(6,6) covariance of ``step.T_o_c``."""

    def reset(self, T_o_c: np.ndarray, cov: np.ndarray) -> None:
        """Restart from the coasted pose ``T_o_c`` with covariance ``cov``."""


def propagate_cov(cov_old: np.ndarray, T_o_c1: np.ndarray, T_c1_c3: np.ndarray, cov_step: np.ndarray) -> np.ndarray:
    """(6,6) covariance of ``T_o_c3 = T_o_c1 @ T_c1_c3`` (first order): ``A cov_old A^T + B cov_step B^T``,
    ``A = [[I, 0], [-skew(R p), I]]``, ``B = blockdiag(R, R)``, ``R = R_o_c1``, ``p = t_c1_c3``."""
    R = T_o_c1[:3, :3]
    A = np.eye(6)
    A[3:, :3] = -skew(R @ T_c1_c3[:3, 3])
    B = np.zeros((6, 6))
    B[:3, :3] = B[3:, 3:] = R
    C = A @ cov_old @ A.T + B @ cov_step @ B.T
    return 0.5 * (C + C.T)


class PropagatedCovariance:
    """``cov="propagated"`` (default): the step's first-order covariance chained by :func:`propagate_cov`."""

    def on_step(self, step: Step) -> np.ndarray:
        return propagate_cov(step.cov_kf, step.T_o_kf, step.T_kf_c, step.cov_step)

    def reset(self, T_o_c: np.ndarray, cov: np.ndarray) -> None:
        """Nothing to restart: the next step chains onto the estimator's keyframe covariance."""
