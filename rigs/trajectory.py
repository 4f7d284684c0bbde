"""The one trajectory type: integer-nanosecond timestamps and 4x4 poses ``T_ref_x``."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigs.errors import RecordError


@dataclass(frozen=True)
class Trajectory:
    """``t_ns`` (N,) int64 nanoseconds, strictly increasing; ``T`` (N,4,4) poses ``T_ref_x``.

    ``ref`` and ``frame`` name the two frames (e.g. ``ref="w", frame="c0"``).
    """

    t_ns: np.ndarray
    T: np.ndarray
    ref: str = "w"
    frame: str = "b"

    def __post_init__(self):
        t = np.asarray(self.t_ns, dtype=np.int64).reshape(-1)
        T = np.asarray(self.T, dtype=float)
        if T.ndim != 3 or T.shape[1:] != (4, 4) or T.shape[0] != t.shape[0]:
            raise RecordError(f"Trajectory: expected t_ns (N,) and T (N,4,4), got {t.shape} and {T.shape}")
        if not np.all(np.isfinite(T)):
            raise RecordError("Trajectory: poses contain NaN or inf")
        if t.size > 1 and np.any(np.diff(t) <= 0):
            raise RecordError("Trajectory: timestamps must be strictly increasing")
        object.__setattr__(self, "t_ns", t)
        object.__setattr__(self, "T", T)

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])

    @property
    def positions(self) -> np.ndarray:
        """(N,3) translations ``t_ref_x``."""
        return self.T[:, :3, 3]

    @property
    def rotations(self) -> np.ndarray:
        """(N,3,3) rotations ``R_ref_x``."""
        return self.T[:, :3, :3]

    @property
    def t_s(self) -> np.ndarray:
        """(N,) seconds since the first sample, for plots."""
        return (self.t_ns - self.t_ns[0]) * 1e-9 if len(self) else np.zeros(0)

    @property
    def path_length(self) -> float:
        """Sum of distances between consecutive positions (m)."""
        if len(self) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(self.positions, axis=0), axis=1).sum())

    def transformed(self, T_new_ref: np.ndarray, T_x_y: np.ndarray | None = None, ref: str | None = None,
                    frame: str | None = None) -> "Trajectory":
        """Left-multiply by ``T_new_ref`` and optionally right-multiply by ``T_x_y`` (change of tracked frame)."""
        T = np.einsum("ij,njk->nik", T_new_ref, self.T)
        if T_x_y is not None:
            T = T @ T_x_y
        return Trajectory(self.t_ns, T, ref or self.ref, frame or self.frame)

    def subset(self, mask_or_index) -> "Trajectory":
        return Trajectory(self.t_ns[mask_or_index], self.T[mask_or_index], self.ref, self.frame)
