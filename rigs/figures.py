"""Figure files shared by the simulator's writers and the evaluation plots: matplotlib's Agg backend
(no display needed), every file written atomically (:mod:`rigs.atomic_io`)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from rigs.atomic_io import atomic_write  # noqa: E402


def save_figure(fig, path) -> Path:
    """Save and close ``fig`` atomically (temp name, then rename); format from the suffix."""
    path = Path(path)
    try:
        return atomic_write(path, lambda tmp: fig.savefig(tmp, format=(path.suffix.lstrip(".") or "png"), dpi=120,
                                                           bbox_inches="tight"))
    finally:
        plt.close(fig)
