"""Seed 000 (Lin, Tseng, Chiang): stereo VO by ROP (relative orientation parameter) adjustment.

Notation: images 1, 2 = left, right at epoch t; 3, 4 = left, right at t+1; ``C_k`` their OpenCV
camera frames. ``R_i_j = R_j^i`` (rotation C_j -> C_i), ``t_i_j = r_j^i`` (origin of C_j in C_i),
``rhat_i_j`` its unit direction. The object frame O of one epoch pair is C_1.

Modules: :mod:`relative` (one ROP from point matches), :mod:`initial_eops` (initial EOPs of images 3, 4),
:mod:`adjustment` (two-step network adjustment, eqs. 1-3), :mod:`estimator` (the "rop" estimator,
configured by :mod:`rop_config`; its ROP gates in :mod:`consensus`, front-ends in :mod:`tracks` and
:mod:`matching`), and its covariance: :mod:`uncertainty` (interface, first order), :mod:`propagation`
(ROP covariances through the adjustment), :mod:`chain_bootstrap` with :mod:`bootstrap_cov`.
"""
from vo.rop.relative import RopMeasurement, estimate_rop
from vo.rop.initial_eops import InitialEops, initial_eops
from vo.rop.adjustment import RopAdjustmentResult, adjust_rops

__all__ = ["RopMeasurement", "estimate_rop", "InitialEops", "initial_eops",
           "RopAdjustmentResult", "adjust_rops"]
