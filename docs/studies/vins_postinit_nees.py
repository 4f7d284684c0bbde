"""NEES of a VINS consistency run after initialisation: ``python docs/studies/vins_postinit_nees.py OUT/runs.npz``.

``vo-testbed consistency`` scores every frame after 5 cm of motion; a monocular VINS reports the identity with
:data:`vo.vins.covariance.INIT_COV` until it initialises, which swamps that summary. This scores the frames
after every initialised run has started (runs that never initialise are listed and left out): position and
attitude NEES (dof 3 each), and the end-point error spread against the runs' mean predicted standard deviation.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from rigs.geometry import pose_error_left
from vo.errors import VoError
from vo.vins.covariance import INIT_COV


def post_init_nees(T_est: np.ndarray, cov: np.ndarray, T_true: np.ndarray) -> dict:
    """``T_est`` (R,N,4,4), ``cov`` (R,N,6,6), ``T_true`` (N,4,4) as ``runs.npz`` holds them."""
    init = np.all(np.isclose(cov, INIT_COV), axis=(2, 3))
    ok = np.flatnonzero(~init[:, -1])
    if len(ok) < 2:
        raise VoError(f"post_init_nees: {len(ok)} of {len(T_est)} runs initialised; need >= 2")
    start = int(max(np.argmax(~init[r]) for r in ok))
    e = np.array([pose_error_left(T_true[start:], T_est[r, start:]) for r in ok])
    P = cov[ok, start:]
    nees = lambda x, C: np.einsum("rti,rtij,rtj->rt", x, np.linalg.inv(C), x)   # noqa: E731
    end = e[:, -1, 3:]
    return {"runs": len(T_est), "initialised": len(ok), "first_scored_frame": start,
            "nees_position": float(nees(e[..., 3:], P[..., 3:, 3:]).mean()),
            "nees_attitude": float(nees(e[..., :3], P[..., :3, :3]).mean()),
            "end_measured_std_m": np.round(end.std(0, ddof=1), 4).tolist(),
            "end_predicted_std_m":
                np.round(np.sqrt(np.diagonal(P[:, -1, 3:, 3:], axis1=1, axis2=2)).mean(0), 4).tolist(),
            "end_measured_sqrt_trace_m": float(np.sqrt(np.trace(np.cov(end.T)))),
            "end_predicted_sqrt_trace_m": float(np.sqrt(np.trace(P[:, -1, 3:, 3:], axis1=1, axis2=2)).mean())}


def main(argv=None) -> int:
    """CLI: one-line error and exit 2 on a missing or malformed ``runs.npz``."""
    ap = argparse.ArgumentParser(prog="vins_postinit_nees.py", description=__doc__.splitlines()[0])
    ap.add_argument("runs_npz", help="runs.npz written by vo-testbed consistency")
    a = ap.parse_args(argv)
    try:
        with np.load(a.runs_npz) as d:
            missing = [k for k in ("T_est", "cov", "T_true") if k not in d.files]
            if missing:
                raise VoError(f"{a.runs_npz}: no field {missing[0]!r} (a vo-testbed consistency runs.npz has "
                              f"T_est, cov, T_true)")
            print(post_init_nees(d["T_est"], d["cov"], d["T_true"]))
    except (OSError, ValueError) as e:
        print(f"error: {a.runs_npz}: cannot read ({e})", file=sys.stderr)
        return 2
    except VoError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
