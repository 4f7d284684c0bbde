"""Summary statistics of an error array, as evo reports them (population std, RMSE)."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class ErrorStats:
    """``rmse = sqrt(mean(e^2))``, ``std`` is the population std (numpy/evo ``np.std``); ``n`` samples."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    n: int

    @classmethod
    def of(cls, e) -> "ErrorStats":
        """(N,) errors -> stats; an empty array gives NaN figures and ``n=0``."""
        e = np.asarray(e, dtype=float).reshape(-1)
        if e.size == 0:
            nan = float("nan")
            return cls(nan, nan, nan, nan, nan, nan, 0)
        return cls(float(np.sqrt(np.mean(e ** 2))), float(np.mean(e)), float(np.median(e)),
                   float(np.std(e)), float(np.min(e)), float(np.max(e)), int(e.size))

    def to_dict(self) -> dict:
        return asdict(self)
