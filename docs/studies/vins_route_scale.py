"""Scale of a whole-route ``vins`` run over time, from the per-frame poses ``vins_start_table.py --traj`` saved.

    python docs/studies/vins_route_scale.py DATASET TRAJ.npz [DATASET TRAJ.npz ...] [--segment-s 10] [--brief]

Per segment of ``--segment-s`` seconds of covered frames (status ``ok``/``keyframe``): the true speed (m/s),
the scale error of the emitted poses over the segment (estimated / true path length - 1, %) and the
along-track and total position error at its end (poses aligned at the first covered frame, m). Prints one
line per segment (not with ``--brief``) and a summary per dataset: the range of the segment scale errors at
more than 1 m/s, the largest along-track error, where, and as a share of the true path from the first pose to there, the
end-point error. Bad input: one ``error:`` line,
exit 2.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from rigs.errors import TestbedError
from vo.dataset import open_dataset

COVERED = ("ok", "keyframe")


def segments(t_ns, T_gt, T_est, status, segment_s: float) -> list:
    """Rows (t0 s, t1 s, true speed, scale error %, along-track error m, position error m) per segment."""
    idx = np.array([k for k, s in enumerate(status) if s in COVERED])
    if len(idx) < 2:
        return []
    Tg, Te = T_gt[idx], T_est[idx]
    Te = Tg[0] @ np.linalg.inv(Te[0]) @ Te
    t = (t_ns[idx] - t_ns[0]) * 1e-9
    rows, a = [], 0
    while a < len(idx) - 1:
        b = int(min(np.searchsorted(t, t[a] + segment_s), len(idx) - 1))
        b = max(b, a + 1)
        dg = np.sum(np.linalg.norm(np.diff(Tg[a:b + 1, :3, 3], axis=0), axis=1))
        de = np.sum(np.linalg.norm(np.diff(Te[a:b + 1, :3, 3], axis=0), axis=1))
        fwd = Tg[b, :3, 2]
        err = Te[b, :3, 3] - Tg[b, :3, 3]
        rows.append((t[a], t[b], dg / max(t[b] - t[a], 1e-9), (de / dg - 1) * 100 if dg > 1 else float("nan"),
                     float(err @ fwd), float(np.linalg.norm(err))))
        a = b
    return rows


def summary(rows) -> str:
    sc = np.array([r[3] for r in rows if r[2] > 1.0])
    k = int(np.argmax([abs(r[4]) for r in rows]))
    path = sum(r[2] * (r[1] - r[0]) for r in rows[:k + 1])         # true path from the first pose to there
    return (f"segment scale error {sc.min():+.1f} .. {sc.max():+.1f} %, largest along-track error "
            f"{rows[k][4]:+.1f} m at {rows[k][1]:.0f} s ({100 * rows[k][4] / path:+.1f} % of {path:.0f} m), "
            f"end error {rows[-1][5]:.2f} m")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", type=Path, metavar="DATASET TRAJ.npz")
    ap.add_argument("--segment-s", type=float, default=10.0)
    ap.add_argument("--brief", action="store_true")
    a = ap.parse_args(argv)
    if len(a.pairs) % 2:
        print("error: give DATASET TRAJ.npz pairs", file=sys.stderr)
        return 2
    for dataset, traj in zip(a.pairs[::2], a.pairs[1::2]):
        try:
            gt = open_dataset(dataset).groundtruth_cam0()
            z = np.load(traj)
            n = len(z["status"])
            if not np.array_equal(z["t_ns"], np.asarray(gt.t_ns[:n], np.int64)):
                raise TestbedError(f"{traj}: t_ns does not match {dataset}'s ground truth")
            rows = segments(np.asarray(gt.t_ns[:n], np.int64), gt.T[:n], z["T_o_c0"],
                            [str(s) for s in z["status"]], a.segment_s)
        except (TestbedError, OSError, KeyError, ValueError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        if not a.brief:
            print(f"{dataset} {traj}\n t0 s  t1 s  speed m/s  scale err %  along m  error m")
            for r in rows:
                print(f"{r[0]:5.1f} {r[1]:5.1f} {r[2]:9.2f} {r[3]:+11.2f} {r[4]:+8.2f} {r[5]:8.2f}")
        print(f"{Path(dataset).name}: " + (summary(rows) if rows else "no covered frames"), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
