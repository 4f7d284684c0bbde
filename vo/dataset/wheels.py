"""``wheels.csv`` (``#timestamp [ns],left_ticks,right_ticks``) -> :class:`rigs.records.WheelSamples`."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np

from rigs.records import WheelSamples
from vo.dataset.csvio import data_rows
from vo.errors import DatasetError


def read_wheels_csv(path: Path) -> Optional[WheelSamples]:
    """Strictly parsed wheel ticks; None when the file does not exist (no wheels recorded)."""
    path = Path(path)
    if not path.is_file():
        return None
    rows = []
    for n, parts in data_rows(path, "wheels", 3):
        try:
            rows.append([int(p) for p in parts])
        except ValueError:
            raise DatasetError(f"{path}: line {n}: expected t_ns,left_ticks,right_ticks integers, "
                               f"got {','.join(parts)[:60]!r}") from None
    a = np.array(rows, dtype=np.int64).reshape(-1, 3)
    if a.shape[0] > 1 and np.any(np.diff(a[:, 0]) <= 0):
        k = int(np.argmax(np.diff(a[:, 0]) <= 0))
        raise DatasetError(f"{path}: timestamps must increase strictly (row {k + 2} of the data)")
    return WheelSamples(a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy())
