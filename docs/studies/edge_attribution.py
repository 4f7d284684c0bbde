"""What a depth-edge detector for ``klt-pnp`` must remove: drop landmarks by their true disparity step.

The ablation ``urban_pnp_drift_ablation.py`` (docs/estimators.md, "Cause of klt-pnp's remaining urban drift")
drops every landmark whose 5x5 true-depth window is not one plane in inverse depth within 0.5 % ("edge", down
to steps of a fraction of a pixel) and finds the drift gone. A label-free test sees only larger steps and also
drops plane landmarks. This study separates the two with the truth (same runner, product stereo depth and KLT
tracks, oracle segmentation: moving features out of the PnP): per variant it drops

* ``edges >= S px``: the edge landmarks whose 5x5 window spans at least ``S`` px of true disparity
  (``S`` = 0 is the ablation's row "edge landmarks dropped", ``S`` = inf drops none: the product); the rest stay;
* ``+ plane P``: in addition a share ``P`` of the plane landmarks, drawn at random (seeded): the false
  positives of a test that removes that share of them.

and prints the ablation's columns (end rotation error, mean signed step rotation error, drift)::

    vo-testbed generate --scenario urban-dynamic --segmentation --depth --seed N --out DATA
    python docs/studies/edge_attribution.py DATA [--max-frames 998] [--variant S:P ...]
"""
from __future__ import annotations

import argparse

import numpy as np

import urban_pnp_drift_ablation as upda          # the sibling study: its truth inputs and runner
from sim.app.validation.exact_points import backproject, local_depth
from track_residual_labels import disparity_step


class StepInputs(upda.TruthInputs):
    """The ablation's truth inputs whose landmark selection drops edges by disparity step and plane
    landmarks at random (``step_px``, ``plane_share``)."""

    step_px = 0.0
    plane_share = 0.0

    def _depth(self, p_l):
        cam, depth = self.rig.cameras[0], np.asarray(self.ds.depth(self.k, 0), float)
        z, ok = local_depth(depth, p_l)
        fb = float(cam.K[0, 0]) * float(np.linalg.norm(self.rig.T_c0_c1[:3, 3]))
        big = ~ok & (disparity_step(depth, p_l, fb) >= self.step_px)
        drop_plane = ok & (self.rng.random(len(ok)) < self.plane_share)
        return backproject(cam, p_l, z), ok, ~big & ~drop_plane


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--max-frames", type=int, default=998)
    ap.add_argument("--variant", action="append", help="S:P (edge step px, plane share); default a set")
    a = ap.parse_args()
    ds = upda.open_dataset(a.dataset)
    variants = [tuple(float(x) for x in v.split(":")) for v in (a.variant or
                ["inf:0", "0:0", "0.5:0", "1:0", "2:0", "3:0", "0:0.26", "3:0.26", "inf:0.26"])]
    print(f"{a.dataset}, frames 0-{min(a.max_frames, len(ds)) - 1}, oracle segmentation, product stereo depth and "
          "tracks; deg, step bias mdeg")
    print("| dropped | roll | pitch | step bias roll / pitch | drift % | vertical m |")
    print("|---|---|---|---|---|---|")
    abl = upda.Ablation("product", depth_ok="valid")
    for step, share in variants:
        inputs = type("Inputs", (StepInputs,), {"step_px": step, "plane_share": share})
        r = upda.run(ds, abl, a.max_frames, {"disp": 0.0, "px": 0.0}, {}, inputs=inputs)
        name = ("none (the product)" if step == np.inf else f"edges >= {step:g} px") + (f" + {100 * share:.0f} % plane"
                                                                              if share else "")
        print(f"| {name} | {r['rot'][2]:+.2f} | {r['rot'][0]:+.2f} | {r['step'][2]:+.2f} / {r['step'][0]:+.2f} | "
              f"{r['drift']:.2f} | {r['vert']:+.2f} |", flush=True)


if __name__ == "__main__":
    main()
