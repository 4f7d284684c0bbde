"""Strict, line-numbered readers for the small text files of EuRoC/KITTI datasets.

Every problem raises a one-line :class:`vo.errors.DatasetError` naming the file, the line and
the field, e.g. ``.../imu0/data.csv: line 12: expected 7 comma-separated values, got 4``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vo.errors import DatasetError


def read_text(path: Path, what: str) -> str:
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: {what} file not found")
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: cannot read {what} file: {exc}") from None


def data_lines(path: Path, what: str):
    """Yield ``(line_number, stripped_line)`` of non-blank, non-``#`` lines."""
    for n, line in enumerate(read_text(path, what).splitlines(), 1):
        line = line.strip()
        if line and not line.startswith("#"):
            yield n, line


def data_rows(path: Path, what: str, n_fields: int):
    """Yield ``(line_number, fields)`` of the data lines, each split at commas into exactly ``n_fields``
    fields (else a one-line DatasetError naming the file and line)."""
    for n, line in data_lines(path, what):
        parts = line.split(",")
        if len(parts) != n_fields:
            raise DatasetError(f"{path}: line {n}: expected {n_fields} comma-separated values, got {len(parts)}")
        yield n, parts


def _timestamp(tok: str, path, n: int) -> int:
    try:
        return int(tok)
    except ValueError:
        raise DatasetError(f"{path}: line {n}: timestamp [ns] must be an integer, got {tok[:30]!r}") from None


def read_numeric_csv(path, n_values: int, what: str, names=None) -> tuple[np.ndarray, np.ndarray]:
    """``t_ns, v1..v_n`` rows -> ``(t_ns (N,) int64 strictly increasing, values (N, n_values) float)``."""
    path = Path(path)
    t, rows = [], []
    for n, parts in data_rows(path, what, n_values + 1):
        ts = _timestamp(parts[0].strip(), path, n)
        try:
            vals = [float(p) for p in parts[1:]]
        except ValueError:
            raise DatasetError(f"{path}: line {n}: expected numbers, got {','.join(parts)[:60]!r}") from None
        bad = [j for j, v in enumerate(vals) if not math.isfinite(v)]
        if bad:
            col = names[bad[0]] if names else f"column {bad[0] + 2}"
            raise DatasetError(f"{path}: line {n}: {col} is NaN or inf")
        if t and ts <= t[-1]:
            raise DatasetError(f"{path}: line {n}: timestamp {ts} is not after the previous {t[-1]}")
        t.append(ts)
        rows.append(vals)
    return np.array(t, dtype=np.int64), np.array(rows, dtype=float).reshape(-1, n_values)


def read_image_list(path) -> tuple[np.ndarray, list]:
    """EuRoC ``camK/data.csv`` (``#timestamp [ns],filename``) -> ``(t_ns (N,) int64, filenames)``."""
    path = Path(path)
    t, names = [], []
    for n, line in data_lines(path, "camera list"):
        parts = [p.strip() for p in line.split(",")]
        if len(parts) != 2 or not parts[1]:
            raise DatasetError(f"{path}: line {n}: expected 'timestamp [ns],filename', got {line[:60]!r}")
        ts = _timestamp(parts[0], path, n)
        if t and ts <= t[-1]:
            raise DatasetError(f"{path}: line {n}: timestamp {ts} is not after the previous {t[-1]}")
        t.append(ts)
        names.append(parts[1])
    return np.array(t, dtype=np.int64), names


def read_column(path, what: str, integer: bool) -> np.ndarray:
    """One number per line (KITTI ``times.txt`` seconds, or our ``times_ns.txt``)."""
    out = []
    for n, line in data_lines(path, what):
        tok = line.split()[0]
        try:
            v = int(tok) if integer else float(tok)
        except ValueError:
            raise DatasetError(f"{path}: line {n}: expected a number, got {tok[:30]!r}") from None
        if not integer and not math.isfinite(v):
            raise DatasetError(f"{path}: line {n}: time is NaN or inf")
        out.append(v)
    return np.array(out, dtype=np.int64 if integer else float)
