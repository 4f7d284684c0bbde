"""Seed 000 Fig. 5 on rendered data: the ROP network adjustment improves on the initial EOPs.

On ``campus_short`` (6 s campus, cart27, seed 0; 42 epochs solved with four ROPs, keyframe ->
current frame) the measured mean errors of ``T_kf_c`` against ``groundtruth_cam0()`` were:

==========================  ===============  ==============
EOPs                        rotation (deg)   position (mm)
==========================  ===============  ==============
initial, ``"minimal"``      0.0113           4.25
initial, ``"network"``      0.0094           3.99
adjusted (eqs. 1-3)         0.0094           3.92
==========================  ===============  ==============

The claim is tested against the paper's minimal initial EOPs (ROP 1-3 rotation, rays 1-3 / 2-3):
our default "network" initial already averages all four ROPs, and its rotation *is* the step-1
solution (the inlier-weighted chordal mean solves eq. 1 with hard orthonormality), so the
adjustment's gain over it is in the positions only (~2 %). Everything is seeded (rendering,
RANSAC), so the figures are reproducible; the bounds leave a margin for platform float noise.
"""
import numpy as np

from vo.dataset import open_dataset
from vo.rop.epochs import relative_pose_error, true_relative
from vo.rop.estimator import RopEstimator


def _errors(path):
    ds = open_dataset(path)
    gt = ds.groundtruth_cam0()
    G = {int(t): T for t, T in zip(gt.t_ns, gt.T)}
    est = RopEstimator(ds.rig)
    for f in ds.frames():
        est.process(f)
    recs = [r for r in est.epochs if r.kind == "rops" and r.T_kf_c_minimal is not None]
    keys = ("T_kf_c_minimal", "T_kf_c_initial", "T_kf_c_adjusted")
    return len(recs), {k: np.array([relative_pose_error(getattr(r, k), true_relative(G, r)) for r in recs])
                       for k in keys}


def test_adjustment_improves_on_initial_eops(campus_short):
    n, e = _errors(campus_short)
    assert n >= 20                                          # measured 42 epochs with four ROPs
    mini, net, adj = (e[k].mean(axis=0) for k in ("T_kf_c_minimal", "T_kf_c_initial", "T_kf_c_adjusted"))
    # Fig. 5: adjusted < minimal initial, in rotation (measured -17 %) and position (-8 %)
    assert adj[0] < 0.95 * mini[0], np.degrees([adj[0], mini[0]])
    assert adj[1] < 0.97 * mini[1], [adj[1], mini[1]]
    # and never worse than the network initial it starts from (rotation equal, position -2 %)
    assert adj[0] <= net[0] * 1.001 and adj[1] <= net[1] * 1.001, (adj, net)
    assert np.degrees(adj[0]) < 0.05 and adj[1] < 0.01     # sanity: ROP epochs are sub-cm, sub-0.05 deg
