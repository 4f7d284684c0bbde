"""Stage timings of the cross-site localizer on chosen site pairs of a traverse dataset, without
localizing the sites before them (``vo-testbed bench localize --pair K``).

Pair ``K`` is site ``K-1`` -> site ``K``. The previous site is held at its pose from a poses file
(``site_poses_tum.txt`` of a ``vo-testbed localize`` run on the same dataset: the pair then sees
exactly the inputs it had in that run, up to the file's 1 ns / 1e-9 rounding) or, without one, at its
true pose; the current site's prior is set as :func:`vo.crosssite.localizer.localize_traverse` sets it
(:func:`vo.crosssite.localizer.site_prior`).
"""
from __future__ import annotations

import numpy as np

from rigs.trajfile import read_tum
from vo.crosssite.localizer import localize_site, site_prior
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.traverse_eval import dataset_root
from vo.crosssite.truth import tie_truth_stats
from vo.dataset.traverse_reader import read_traverse
from vo.errors import DatasetError


def previous_poses(poses_path, site_t_ns: np.ndarray) -> np.ndarray:
    """(S,4,4) T_w_b at each of the site times ``site_t_ns`` (S,) from a TUM file holding one pose
    per site time (within 1 ms)."""
    traj = read_tum(poses_path)
    k = np.abs(traj.t_ns[None, :] - np.asarray(site_t_ns, np.int64)[:, None]).argmin(axis=1)
    off = np.abs(traj.t_ns[k] - site_t_ns)
    if np.any(off > 1_000_000):
        bad = int(np.argmax(off > 1_000_000))
        raise DatasetError(f"{poses_path}: no pose at the site time {int(site_t_ns[bad])} ns (nearest "
                           f"{off[bad] / 1e9:.3f} s away); expected the site_poses_tum.txt of this dataset")
    return traj.T[k]


def localize_pairs(path, cfg: CrossSiteConfig, pairs, poses_path=None) -> list:
    """Localize site pairs ``K-1 -> K`` for each ``K`` in ``pairs`` (OpenCV on one thread, the
    localizer's own ``cfg.workers`` threads). -> one dict per pair: site, status, tie_points,
    true_inliers, ba_err_m (position error against the truth), time_s, timings_s."""
    import cv2
    cv2.setNumThreads(1)
    root = dataset_root(path)
    pairs = sorted(set(int(k) for k in pairs))
    tr = read_traverse(root, max_sites=max(pairs) + 1)
    if pairs[0] < 1 or pairs[-1] >= len(tr.sites):
        raise DatasetError(f"--pair {pairs[0] if pairs[0] < 1 else pairs[-1]}: the traverse has site pairs "
                           f"1..{len(tr.sites) - 1}")
    before = np.array(pairs) - 1
    T_prevs = previous_poses(poses_path, tr.site_t_ns[before]) if poses_path else tr.T_w_b_true[before]
    rows = []
    for k, T_prev in zip(pairs, T_prevs):
        prev = tr.sites[k - 1]
        r = localize_site(prev, T_prev, site_prior(prev, T_prev, tr.sites[k], cfg), cfg)
        truth = tie_truth_stats(prev, tr.sites[k], r.ties, tr.T_w_b_true[k - 1], tr.T_w_b_true[k])
        rows.append({"site": k, "status": r.status, "tie_points": r.n_tie_points,
                     "true_inliers": truth.get("n_true_inliers", 0),
                     "ba_err_m": round(float(np.linalg.norm(tr.T_w_b_true[k][:3, 3] - r.T_w_b[:3, 3])), 4),
                     "time_s": round(float(r.timings_s["total"]), 2),
                     "timings_s": {name: round(v, 3) for name, v in r.timings_s.items()}})
    return rows
