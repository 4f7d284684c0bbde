"""Run-mean end-point error of a ``vo-testbed consistency`` output (docs/studies/rop_consistency.md).

Usage: .venv/bin/python docs/studies/mc_end_errors.py OUT_DIR [OUT_DIR ...]
Reads OUT_DIR/runs.npz; per run, the error of the last pose (left perturbation, camera axes x right,
y down, z forward) relative to the run's own first true pose (:func:`sim.app.nees.end_errors`);
prints mean +- standard error and std over the runs, and the rms end-position error."""
import sys

import numpy as np

from sim.app.nees import end_errors

np.set_printoptions(precision=3, suppress=True, linewidth=200)
for path in sys.argv[1:]:
    rot, pos = end_errors(dict(np.load(f"{path}/runs.npz")))
    rot, pos = rot * 1e3, pos * 1e3
    n = len(rot)
    print(f"{path}: {n} runs")
    print("  end rotation (mrad) mean", rot.mean(0), "+-", rot.std(0) / np.sqrt(n), "std", rot.std(0))
    print("  end position (mm)   mean", pos.mean(0), "+-", pos.std(0) / np.sqrt(n), "std", pos.std(0),
          "rms", np.sqrt((pos ** 2).sum(1).mean()))
