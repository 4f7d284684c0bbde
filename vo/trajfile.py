"""Trajectory files in the formats other tools (evo, KITTI devkit, EuRoC tools) read.

- TUM: ``timestamp tx ty tz qx qy qz qw`` (seconds; quaternion order x, y, z, w).
- KITTI: 12 numbers per line, the row-major top 3x4 of ``T``; no timestamps (a
  separate ``times.txt`` in seconds gives them).
- EuRoC ground truth: ``#timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...`` (Hamilton w, x, y, z).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rigs.io_yaml import write_text_atomic as _atomic_write
from vo.errors import DatasetError
from rigs.geometry import R_from_quat_wxyz, R_from_quat_xyzw, quat_xyzw_from_R, make_T
from vo.trajectory import Trajectory


def _load_table(path: Path, min_cols: int, delimiter=None) -> np.ndarray:
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: trajectory file not found")
    try:
        rows = np.loadtxt(path, comments="#", delimiter=delimiter, ndmin=2)
    except ValueError as e:
        raise DatasetError(f"{path}: malformed trajectory file ({e})") from None
    if rows.size == 0 or rows.shape[1] < min_cols:
        raise DatasetError(f"{path}: expected at least {min_cols} columns per line, got {rows.shape[1] if rows.size else 0}")
    if not np.all(np.isfinite(rows)):
        raise DatasetError(f"{path}: contains NaN or inf")
    return rows


def _sorted_unique(t_ns: np.ndarray, T: np.ndarray, path) -> tuple:
    order = np.argsort(t_ns, kind="stable")
    t_ns, T = t_ns[order], T[order]
    if np.any(np.diff(t_ns) <= 0):
        raise DatasetError(f"{path}: duplicate timestamps")
    return t_ns, T


def write_tum(path, traj: Trajectory) -> None:
    """Write ``traj`` as a TUM file (seconds with nanosecond precision, quaternion x y z w)."""
    q = quat_xyzw_from_R(traj.rotations)
    p = traj.positions
    lines = [f"# TUM trajectory: T_{traj.ref}_{traj.frame}; timestamp tx ty tz qx qy qz qw"]
    for k in range(len(traj)):
        t = traj.t_ns[k]
        lines.append(f"{t // 1_000_000_000}.{t % 1_000_000_000:09d} "
                     + " ".join(f"{v:.9f}" for v in p[k]) + " " + " ".join(f"{v:.9f}" for v in q[k]))
    _atomic_write(path, "\n".join(lines) + "\n")


def _seconds_to_ns(path) -> np.ndarray:
    """Parse the first column of a text file as decimal seconds into exact int64 ns."""
    out = []
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        tok = line.split()[0].replace(",", "")
        whole, _, frac = tok.partition(".")
        out.append(int(whole or 0) * 1_000_000_000 + int((frac + "000000000")[:9]) * (-1 if whole.startswith("-") else 1))
    return np.array(out, dtype=np.int64)


def read_tum(path, ref: str = "w", frame: str = "b") -> Trajectory:
    """Read a TUM file -> Trajectory."""
    rows = _load_table(path, 8)
    t_ns = _seconds_to_ns(path)
    T = np.array([make_T(R_from_quat_xyzw(r[4:8]), r[1:4]) for r in rows])
    t_ns, T = _sorted_unique(t_ns, T, path)
    return Trajectory(t_ns, T, ref, frame)


def write_kitti(path, traj: Trajectory, times_path=None) -> None:
    """Write KITTI poses (row-major 3x4), and optionally ``times.txt`` in seconds."""
    lines = [" ".join(f"{v:.9e}" for v in T[:3, :4].reshape(-1)) for T in traj.T]
    _atomic_write(path, "\n".join(lines) + "\n")
    if times_path is not None:
        _atomic_write(times_path, "\n".join(f"{t * 1e-9:.9e}" for t in traj.t_ns - traj.t_ns[0]) + "\n")


def read_kitti(path, times_path=None, ref: str = "c0_0", frame: str = "c0", rate_hz: float = 10.0) -> Trajectory:
    """Read KITTI poses; timestamps from ``times_path`` (seconds) or ``k / rate_hz``."""
    rows = _load_table(path, 12)
    if rows.shape[1] != 12:
        raise DatasetError(f"{path}: KITTI poses need exactly 12 numbers per line, got {rows.shape[1]}")
    T = np.tile(np.eye(4), (rows.shape[0], 1, 1))
    T[:, :3, :4] = rows.reshape(-1, 3, 4)
    if times_path is not None:
        t_ns = np.round(_load_table(times_path, 1)[:, 0] * 1e9).astype(np.int64)
        if t_ns.shape[0] != T.shape[0]:
            raise DatasetError(f"{times_path}: {t_ns.shape[0]} times for {T.shape[0]} poses in {path}")
    else:
        t_ns = np.round(np.arange(T.shape[0]) / rate_hz * 1e9).astype(np.int64)
    return Trajectory(t_ns, T, ref, frame)


def read_euroc_groundtruth(path, ref: str = "w", frame: str = "i") -> Trajectory:
    """Read EuRoC ``state_groundtruth_estimate0/data.csv`` (or any ``t_ns, p, q_wxyz`` csv)."""
    rows = _load_table(path, 8, delimiter=",")
    t_ns = np.array([int(line.split(",")[0]) for line in Path(path).read_text().splitlines()
                     if line.strip() and not line.startswith("#")], dtype=np.int64)
    T = np.array([make_T(R_from_quat_wxyz(r[4:8]), r[1:4]) for r in rows])
    t_ns, T = _sorted_unique(t_ns, T, path)
    return Trajectory(t_ns, T, ref, frame)


def read_trajectory(path, fmt: str = "auto", **kw) -> Trajectory:
    """Read a trajectory in ``tum``, ``kitti`` or ``euroc`` format (``auto`` guesses from the content)."""
    fmts = ("tum", "kitti", "euroc")
    if fmt == "auto":
        path = Path(path)
        if not path.is_file():
            raise DatasetError(f"{path}: trajectory file not found")
        first = next((l for l in path.read_text().splitlines() if l.strip() and not l.startswith("#")), "")
        fmt = "euroc" if "," in first else ("kitti" if len(first.split()) == 12 else "tum")
    if fmt not in fmts:
        raise DatasetError(f"unknown trajectory format {fmt!r}; valid: {', '.join(fmts)}")
    return {"tum": read_tum, "kitti": read_kitti, "euroc": read_euroc_groundtruth}[fmt](path, **kw)
