"""The output folder of a consistency run: ``consistency.json`` (the summary), ``consistency.png``
(:func:`sim.app.nees.plots.plot_consistency`) and ``runs.npz`` (every run's poses and
covariances and the truth), each written atomically."""
from __future__ import annotations

from pathlib import Path

from rigs.atomic_io import atomic_write_json, atomic_write_npz
from sim.app.nees.plots import plot_consistency
from sim.app.nees.scoring import ConsistencyResult

SUMMARY, PLOT, RUNS = "consistency.json", "consistency.png", "runs.npz"


def write_outputs(res: ConsistencyResult, out_dir) -> dict:
    """Write the three files into ``out_dir`` (created) -> {"summary", "plot", "runs": Path} (no
    ``runs`` when the result holds no per-run data)."""
    out = Path(out_dir)
    paths = {"summary": out / SUMMARY, "plot": out / PLOT}
    plot_consistency(res, paths["plot"])
    atomic_write_json(paths["summary"], res.to_dict(), sort_keys=True)
    if res.runs_data is not None:
        paths["runs"] = atomic_write_npz(out / RUNS, res.runs_data)
    return paths
