"""Trajectory files in the formats other tools (evo, KITTI devkit, EuRoC tools) read.

- TUM: ``timestamp tx ty tz qx qy qz qw`` (seconds; quaternion order x, y, z, w). A file whose
  timestamps are integer nanoseconds (a common slip) is recognised and read as such, with a warning
  on the ``rigs.trajfile`` logger: see :func:`tum_times_ns`.
- KITTI: 12 numbers per line, the row-major top 3x4 of ``T``; no timestamps: a separate ``times.txt``
  in seconds gives them (:func:`kitti_times_path` finds it; no rate is ever assumed when reading a
  trajectory with :func:`read_trajectory`).
- EuRoC ground truth: ``#timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...`` (Hamilton w, x, y, z).

Every problem (missing or empty file, a malformed line, NaN, a zero quaternion, repeated times)
raises a one-line :class:`rigs.errors.RecordError` naming the file and, where it applies, the line.
"""
from __future__ import annotations

import logging
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from rigs.atomic_io import atomic_write_text as _atomic_write
from rigs.errors import RecordError
from rigs.geometry import R_from_quat_wxyz, R_from_quat_xyzw, quat_xyzw_from_R
from rigs.trajectory import Trajectory

LOG = logging.getLogger("rigs.trajfile")
NS_MIN_MAGNITUDE = 1e12   # as seconds: year 33 700; as ns: 17 minutes after the epoch
NS_MIN_STEP = 1e5         # as seconds: 28 h between poses; as ns: 0.1 ms
QUAT_MIN_NORM = 1e-6


def _data_rows(path: Path, delimiter=None) -> tuple[list, list]:
    """``(line_numbers, token_lists)`` of the non-blank, non-``#`` lines; no such line -> RecordError."""
    path = Path(path)
    if not path.is_file():
        raise RecordError(f"{path}: trajectory file not found")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise RecordError(f"{path}: cannot read trajectory file ({e})") from None
    numbers, rows = [], []
    for n, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if s and not s.startswith("#"):
            numbers.append(n)
            rows.append([p.strip() for p in (s.split(delimiter) if delimiter else s.split())])
    if not rows:
        raise RecordError(f"{path}: no poses (the file is empty or holds only comments)")
    return numbers, rows


def _load_table(path: Path, min_cols: int, delimiter=None, exact: bool = False) -> tuple[list, list, np.ndarray]:
    """-> ``(line_numbers, token_lists, values (N, C) float)``; C is the first line's column count."""
    numbers, rows = _data_rows(path, delimiter)
    n_cols = len(rows[0])
    for n, row in zip(numbers, rows):
        if len(row) != n_cols or n_cols < min_cols or (exact and n_cols != min_cols):
            want = f"{min_cols}" if exact else (f"{n_cols}" if n_cols >= min_cols else f"at least {min_cols}")
            raise RecordError(f"{path}: line {n}: expected {want} values, got {len(row)}")
    try:
        values = np.array([[float(v) for v in row] for row in rows], dtype=float)
    except ValueError:
        n, row = next((n, r) for n, r in zip(numbers, rows) if not _all_float(r))
        raise RecordError(f"{path}: line {n}: expected numbers, got {' '.join(row)[:60]!r}") from None
    bad = ~np.all(np.isfinite(values), axis=1)
    if bad.any():
        raise RecordError(f"{path}: line {numbers[int(np.argmax(bad))]}: NaN or inf")
    return numbers, rows, values


def _all_float(row) -> bool:
    try:
        [float(v) for v in row]
        return True
    except ValueError:
        return False


def _check_quats(q: np.ndarray, numbers: list, path) -> None:
    """Refuse a (near) zero quaternion: it is no rotation at all (non-unit ones are normalised)."""
    norms = np.linalg.norm(q, axis=1)
    if np.any(norms < QUAT_MIN_NORM):
        k = int(np.argmax(norms < QUAT_MIN_NORM))
        raise RecordError(f"{path}: line {numbers[k]}: zero quaternion (norm {norms[k]:.3g}); "
                           f"not a rotation")


def _sorted_unique(t_ns: np.ndarray, T: np.ndarray, path, n_cols: int = 8) -> tuple:
    """Sort by time; repeated times -> RecordError (naming the column count when it is not the format's 8)."""
    order = np.argsort(t_ns, kind="stable")
    t_ns, T = t_ns[order], T[order]
    if np.any(np.diff(t_ns) <= 0):
        hint = "" if n_cols == 8 else (f" ({n_cols} values per line where the format has 8"
                                       + ("; KITTI poses have 12: give --format kitti)" if n_cols == 12 else ")"))
        raise RecordError(f"{path}: duplicate timestamps{hint}")
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


def tum_times_ns(tokens: list, numbers: list, path) -> np.ndarray:
    """TUM timestamp tokens -> exact int64 ns.

    Seconds (``1.100000000``, ``1403636579.76``, ``1.1e0``) are the format. Integer nanoseconds are
    recognised when every token is an integer and either the largest is >= 1e12 (as seconds: beyond
    the year 33 000) or the median step is >= 1e5 (as seconds: 28 h between poses); they are read
    as nanoseconds with a warning."""
    try:
        values = [Decimal(tok) for tok in tokens]
    except InvalidOperation:
        n = numbers[next(k for k, tok in enumerate(tokens) if not _all_float([tok]))]
        raise RecordError(f"{path}: line {n}: timestamp is not a number") from None
    integral = all(v == v.to_integral_value() for v in values)
    steps = np.diff(np.array([float(v) for v in values])) if len(values) > 1 else np.zeros(0)
    big = max(abs(v) for v in values) >= Decimal(NS_MIN_MAGNITUDE)
    if integral and (big or (steps.size and float(np.median(steps)) >= NS_MIN_STEP)):
        LOG.warning(f"{path}: timestamps are integers of nanosecond size (first {values[0]}); "
                    f"read as nanoseconds (TUM files hold seconds)")
        scale = 1
    else:
        scale = 1_000_000_000
    t_ns = [int((v * scale).to_integral_value()) for v in values]
    if max(abs(t) for t in t_ns) >= 2 ** 63:
        raise RecordError(f"{path}: timestamp {max(values, key=abs)} too large for int64 nanoseconds")
    return np.array(t_ns, dtype=np.int64)


def read_tum(path, ref: str = "w", frame: str = "b") -> Trajectory:
    """Read a TUM file -> Trajectory (timestamps: see :func:`tum_times_ns`)."""
    numbers, rows, values = _load_table(path, 8)
    t_ns = tum_times_ns([r[0] for r in rows], numbers, path)
    _check_quats(values[:, 4:8], numbers, path)
    T = np.tile(np.eye(4), (len(values), 1, 1))
    T[:, :3, :3] = R_from_quat_xyzw(values[:, 4:8])
    T[:, :3, 3] = values[:, 1:4]
    t_ns, T = _sorted_unique(t_ns, T, path, values.shape[1])
    return Trajectory(t_ns, T, ref, frame)


def _seconds_text(t_ns: int) -> str:
    """Exact seconds with 9 decimals: 1403636579763555584 -> ``1403636579.763555584``."""
    sign, a = ("-" if t_ns < 0 else ""), abs(int(t_ns))
    return f"{sign}{a // 1_000_000_000}.{a % 1_000_000_000:09d}"


def write_kitti(path, traj: Trajectory, times_path=None) -> None:
    """Write KITTI poses (row-major 3x4), and optionally ``times.txt``: the poses' own timestamps in
    seconds, exact to the nanosecond (the clock of the data, not rebased to zero), so that a reader pairs
    them with the ground truth they were estimated against."""
    lines = [" ".join(f"{v:.9e}" for v in T[:3, :4].reshape(-1)) for T in traj.T]
    _atomic_write(path, "\n".join(lines) + "\n")
    if times_path is not None:
        _atomic_write(times_path, "\n".join(_seconds_text(t) for t in traj.t_ns) + "\n")


def kitti_times_path(path, times_path=None) -> Path:
    """The times file of the KITTI poses ``path``: ``times_path`` when given, else ``times.txt`` beside
    it, else the KITTI layout's ``sequences/NN/times.txt`` for ``poses/NN.txt``. None found ->
    RecordError (KITTI poses hold no timestamps, and no rate is assumed)."""
    path = Path(path)
    if times_path is not None:
        if not Path(times_path).is_file():
            raise RecordError(f"{times_path}: times file not found")
        return Path(times_path)
    for cand in (path.parent / "times.txt", path.parent.parent / "sequences" / path.stem / "times.txt"):
        if cand.is_file():
            return cand
    raise RecordError(f"{path}: KITTI poses hold no timestamps and there is no times.txt beside them; "
                       f"give the times (seconds, one line per pose) with --times FILE")


def read_kitti_times(times_path) -> np.ndarray:
    """A ``times.txt`` (seconds, one per line; a ``#`` line is a comment) -> exact int64 ns."""
    numbers, rows, _ = _load_table(times_path, 1, exact=True)
    values = []
    for n, row in zip(numbers, rows):
        try:
            values.append(int((Decimal(row[0]) * 1_000_000_000).to_integral_value()))
        except InvalidOperation:
            raise RecordError(f"{times_path}: line {n}: time is not a number") from None
    return np.array(values, dtype=np.int64)


def read_kitti(path, times_path=None, ref: str = "c0_0", frame: str = "c0", rate_hz: float = 10.0) -> Trajectory:
    """Read KITTI poses; timestamps from ``times_path`` (seconds) or ``k / rate_hz``."""
    _, _, rows = _load_table(path, 12, exact=True)
    T = np.tile(np.eye(4), (rows.shape[0], 1, 1))
    T[:, :3, :4] = rows.reshape(-1, 3, 4)
    if times_path is not None:
        t_ns = read_kitti_times(times_path)
        if t_ns.shape[0] != T.shape[0]:
            raise RecordError(f"{times_path}: {t_ns.shape[0]} times for {T.shape[0]} poses in {path}")
        if np.any(np.diff(t_ns) <= 0):
            k = int(np.argmax(np.diff(t_ns) <= 0))
            raise RecordError(f"{times_path}: time {k + 2} is not after time {k + 1}")
    else:
        t_ns = np.round(np.arange(T.shape[0]) / rate_hz * 1e9).astype(np.int64)
    return Trajectory(t_ns, T, ref, frame)


def read_euroc_groundtruth(path, ref: str = "w", frame: str = "i") -> Trajectory:
    """Read EuRoC ``state_groundtruth_estimate0/data.csv`` (or any ``t_ns, p, q_wxyz`` csv)."""
    numbers, rows, values = _load_table(path, 8, delimiter=",")
    try:
        t_ns = np.array([int(r[0]) for r in rows], dtype=np.int64)
    except (ValueError, OverflowError):
        n = numbers[next(k for k, r in enumerate(rows) if not r[0].lstrip("-").isdigit())]
        raise RecordError(f"{path}: line {n}: timestamp [ns] must be an integer") from None
    _check_quats(values[:, 4:8], numbers, path)
    T = np.tile(np.eye(4), (len(values), 1, 1))
    T[:, :3, :3] = R_from_quat_wxyz(values[:, 4:8])
    T[:, :3, 3] = values[:, 1:4]
    t_ns, T = _sorted_unique(t_ns, T, path)
    return Trajectory(t_ns, T, ref, frame)


def detect_format(path) -> str:
    """``euroc`` (commas), ``kitti`` (12 numbers per line) or ``tum`` (8); any other column count ->
    RecordError naming it (a guess would misread the columns, e.g. rotation entries as timestamps)."""
    _, rows = _data_rows(path)
    if "," in " ".join(rows[0]):
        return "euroc"
    n = len(rows[0])
    if n in AUTO_COLUMNS:
        return AUTO_COLUMNS[n]
    raise RecordError(f"{path}: {n} values per line; a trajectory has 8 (TUM: t tx ty tz qx qy qz qw) or 12 "
                       f"(KITTI: the 3x4 pose, row-major); give --format for another layout")


AUTO_COLUMNS = {8: "tum", 12: "kitti"}


def read_trajectory(path, fmt: str = "auto", times_path=None, **kw) -> Trajectory:
    """Read a trajectory in ``tum``, ``kitti`` or ``euroc`` format (``auto``: :func:`detect_format`).
    KITTI poses take their timestamps from ``times_path`` or the ``times.txt`` :func:`kitti_times_path`
    finds; ``times_path`` with another format -> RecordError."""
    fmts = ("tum", "kitti", "euroc")
    if fmt == "auto":
        fmt = detect_format(path)
    if fmt not in fmts:
        raise RecordError(f"unknown trajectory format {fmt!r}; valid: {', '.join(fmts)}")
    if fmt == "kitti":
        return read_kitti(path, kitti_times_path(path, times_path), **kw)
    if times_path is not None:
        raise RecordError(f"{path}: a times file applies to KITTI poses only; this file is {fmt.upper()}, "
                           f"which carries its own timestamps")
    return {"tum": read_tum, "euroc": read_euroc_groundtruth}[fmt](path, **kw)
