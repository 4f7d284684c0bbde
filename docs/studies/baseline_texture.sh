#!/bin/bash
# Reproduce the baseline x texture study (docs/studies/baseline_texture.md):
#   docs/studies/baseline_texture.sh [OUT]            (default OUT=/tmp/study; run from the repository root)
# Two sweeps (4 baselines x 4 texture levels x 5 seeds, rop and klt-pnp), then the analysis tables.
# A sweep interrupted or re-run resumes from its cell records (docs/sweep.md).
set -euo pipefail
OUT=${1:-/tmp/study}
export MUJOCO_GL=${MUJOCO_GL:-egl}
for scenario in campus-short indoor-short; do
  .venv/bin/vo-testbed sweep --scenario "$scenario" \
      --grid baseline=0.063,0.12,0.27,0.5 --grid scene.texture_richness=0.1,0.3,0.6,1.0 \
      --estimator rop,klt-pnp --seeds 0:5 --out "$OUT/$scenario" --workers 2
done
.venv/bin/python docs/studies/baseline_texture.py "$OUT/campus-short" "$OUT/indoor-short" --json "$OUT/analysis.json"
