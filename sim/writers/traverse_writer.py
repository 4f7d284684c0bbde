"""Write a stop-and-go traverse dataset (seed 001): per-site panoramas, drive streams, truth, a map.

The files only; what goes into them is made by :mod:`sim.generate_traverse`.

Layout (docs/dataset_layout.md, "Traverse datasets"; read back by :mod:`vo.dataset.traverse_reader`)::

    metadata.yaml                 generator, config, traverse knobs, rig, mast model, site count
    rig.yaml                      the rig (rigs.rig_yaml), cameras at pan 0 / nominal tilt
    sites/groundtruth_tum.txt     true T_w_b per site, time = the site's capture time
    sites/dead_reckoning_tum.txt  dead-reckoning T_w_b per site, same times
    sites/site_NN/site.yaml       index, t_ns, T_w_b_true, T_w_b_dr, cov_dr (6x6), pairs:
                                  [{pair, t_ns, pan/tilt commanded and true (rad), left, right}]
    sites/site_NN/pair_K_{left,right}.png    8-bit grey images
    drive/imu0.csv                EuRoC IMU rows (gyro, accel) over the whole traverse
    drive/wheels.csv              t_ns, left_ticks, right_ticks (six wheels as two sides)
    drive/groundtruth.csv         EuRoC ground-truth rows of the body frame b (p, q_wxyz, v, biases)
    map.png                       hill-shaded terrain (orthoimage-like), route and site numbers
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import yaml

from rigs.atomic_io import atomic_write_text
from rigs.geometry import quat_wxyz_from_R
from rigs.trajectory import Trajectory
from rigs.trajfile import write_tum
from sim.writers.common import CsvStream, _plain, write_png
from sim.writers.euroc_writer import GT_HEADER, IMU_HEADER

WHEELS_HEADER = "#timestamp [ns],left_ticks,right_ticks"


class TraverseWriter:
    """The files of a traverse dataset in ``out`` (a claimed folder, :func:`sim.writers.common.claim_folder`);
    :meth:`finish` writes ``metadata.yaml`` last, atomically. :meth:`write_pair` may run on any thread."""

    def __init__(self, out: Path):
        self.out = Path(out)
        (self.out / "sites").mkdir(parents=True, exist_ok=True)
        (self.out / "drive").mkdir(parents=True, exist_ok=True)

    def write_drive(self, imu, states, biases, ticks, enc) -> None:
        """``drive/``: the IMU samples ``imu`` (gyro, accel), the body ground truth ``states`` at the IMU times
        with the true ``biases``, the wheel ``ticks`` and their encoder ``enc`` (``wheels.yaml``)."""
        stream = CsvStream(self.out / "drive" / "imu0.csv", IMU_HEADER, False)
        for t, g, a in zip(imu.t_ns, imu.gyro, imu.accel):
            stream.append(t, [f"{x:.9g}" for x in (*g, *a)])
        stream.close()
        gt = CsvStream(self.out / "drive" / "groundtruth.csv", GT_HEADER, False)
        for k in range(len(imu.t_ns)):
            q = quat_wxyz_from_R(states.T_w_b[k, :3, :3])
            gt.append(imu.t_ns[k], [f"{x:.9g}" for x in (*states.T_w_b[k, :3, 3], *q, *states.v_w[k],
                                                          *biases.b_g[k], *biases.b_a[k])])
        gt.close()
        wh = CsvStream(self.out / "drive" / "wheels.csv", WHEELS_HEADER, False)
        for t, l, r in zip(ticks.t_ns, ticks.left_ticks, ticks.right_ticks):
            wh.append(t, [int(l), int(r)])
        wh.close()
        (self.out / "drive" / "wheels.yaml").write_text(yaml.safe_dump(_plain(dataclasses.asdict(enc)),
                                                                         sort_keys=False))

    def write_pair(self, capture, images) -> dict:
        """``sites/site_NN/pair_K_{left,right}.png`` of ``capture`` (:class:`sim.traverse_plan.Capture`) from the
        grey ``images`` (left, right); returns the pair's record of ``site.yaml``."""
        folder = self.out / "sites" / f"site_{capture.site:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        names = [f"pair_{capture.pair}_{side}.png" for side in ("left", "right")]
        for name, img in zip(names, images):
            write_png(folder / name, img, rgb=False)
        return {"pair": capture.pair, "t_ns": capture.t_ns, "pan_cmd_rad": capture.pan_cmd,
                "tilt_cmd_rad": capture.tilt_cmd, "pan_true_rad": capture.pan_true,
                "tilt_true_rad": capture.tilt_true, "left": names[0], "right": names[1]}

    def write_site(self, k: int, t_ns: int, arc_length_m: float, T_w_b_true, T_w_b_dr, cov_dr, pairs) -> None:
        """``sites/site_NN/site.yaml``: the site's time, true and dead-reckoning pose (4,4), covariance (6,6),
        and its ``pairs`` (records of :meth:`write_pair`)."""
        site = {"index": k, "t_ns": int(t_ns), "arc_length_m": float(arc_length_m), "T_w_b_true": T_w_b_true,
                "T_w_b_dr": T_w_b_dr, "cov_dr": cov_dr, "pairs": pairs}
        folder = self.out / "sites" / f"site_{k:02d}"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "site.yaml").write_text(yaml.safe_dump(_plain(site), sort_keys=False))

    def write_site_tracks(self, t_ns, T_true, T_dr) -> None:
        """``sites/groundtruth_tum.txt`` and ``sites/dead_reckoning_tum.txt``: (S,) times, (S,4,4) poses."""
        _write_tum(self.out / "sites" / "groundtruth_tum.txt", t_ns, T_true)
        _write_tum(self.out / "sites" / "dead_reckoning_tum.txt", t_ns, T_dr)

    def write_map(self, tp, T_dr) -> None:
        """``map.png`` (:func:`write_map`)."""
        write_map(self.out / "map.png", tp, T_dr)

    def finish(self, meta: dict) -> None:
        """``metadata.yaml``, the last file, written atomically: a folder without it is incomplete."""
        atomic_write_text(self.out / "metadata.yaml", yaml.safe_dump(_plain(meta), sort_keys=False))


def _write_tum(path: Path, t_ns, T) -> None:
    write_tum(path, Trajectory(np.asarray(t_ns, np.int64), np.asarray(T), ref="w", frame="b"))


def write_map(path: Path, tp, T_dr=None, extra: dict = None) -> None:
    """Top-down hill-shaded terrain (sun of the scene) with the true route, site numbers and, if
    given, the dead-reckoning sites and ``extra`` {label: (S,2) xy} tracks."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rigs.figures import save_figure
    sc = tp.scene
    xmin, xmax, ymin, ymax = sc.extent_xy()
    gy, gx = np.gradient(sc.z, getattr(sc, "res_m", 0.25))
    n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    shade = np.clip((n @ sc.sun_direction()) / np.linalg.norm(n, axis=-1), 0, 1)
    xy = tp.trajectory.states(np.linspace(tp.trajectory.t0_ns, tp.trajectory.t1_ns, 2000).astype(np.int64)).T_w_b[:, :2, 3]
    sites = tp.T_w_b_sites[:, :2, 3]
    pad = 12.0
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.imshow(shade, cmap="gray", origin="lower", extent=(xmin, xmax, ymin, ymax))
    ax.plot(xy[:, 0], xy[:, 1], "b-", lw=1, label="true traverse")
    ax.plot(sites[:, 0], sites[:, 1], "go", ms=4, label="sites (truth)")
    if T_dr is not None:
        ax.plot(T_dr[:, 0, 3], T_dr[:, 1, 3], "r^--", ms=3, lw=0.8, label="dead reckoning")
    for label, pts in (extra or {}).items():
        ax.plot(pts[:, 0], pts[:, 1], "s-", ms=3, lw=0.8, label=label)
    for k, (x, y) in enumerate(sites):
        ax.annotate(str(k), (x, y), xytext=(4, 4), textcoords="offset points", color="yellow", fontsize=8)
    ax.set_xlim(sites[:, 0].min() - pad, sites[:, 0].max() + pad)
    ax.set_ylim(sites[:, 1].min() - pad, sites[:, 1].max() + pad)
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.legend(loc="best", fontsize=8)
    save_figure(fig, str(path))
