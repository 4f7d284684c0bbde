"""Fan-out of writer calls to a EuRoC and/or a KITTI writer, and a TUM convenience.

``rosbag1``/``rosbag2`` write the EuRoC folder into ``out_dir`` and then convert it with the ``bag_export``
the caller hands in (the app layer's :func:`sim.app.rosbag_export.export_rosbag`, which reads the folder
through the reader API) into ``out_dir/dataset.bag`` (ROS 1) or
``out_dir/rosbag2/`` (ROS 2, MCAP storage); the EuRoC folder stays, so every tool of ours reads it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rigs.atomic_io import atomic_write_text
from rigs.geometry import quat_wxyz_from_R
from rigs.trajfile import write_tum
from sim.errors import SimError
from sim.stage_timer import NO_TIMER
from sim.writers.common import PngOptions

FORMATS = ("euroc", "kitti", "both", "rosbag1", "rosbag2")
BAG_NAMES = {"rosbag1": "dataset.bag", "rosbag2": "rosbag2"}


def check_bag_export(fmt: str, bag_export) -> None:
    """SimError (one line) when a bag format ``fmt`` comes without its ``bag_export`` converter."""
    if fmt in BAG_NAMES and bag_export is None:
        raise SimError(f"format {fmt}: the bag is converted by the app layer's exporter; pass "
                       f"bag_export=sim.app.rosbag_export.export_rosbag (the CLI does)")


def output_paths(out_dir, fmt: str) -> list:
    """The folders (and bag) a ``generate --format fmt`` into ``out_dir`` writes, for messages."""
    out_dir = Path(out_dir)
    if fmt == "both":
        return [out_dir / "euroc", out_dir / "kitti"]
    if fmt in BAG_NAMES:
        return [out_dir, out_dir / BAG_NAMES[fmt]]
    return [out_dir]


def write_tum_groundtruth(path, traj) -> None:
    """Write a ``rigs.trajectory.Trajectory`` as a TUM file (seconds, x y z, qx qy qz qw)."""
    write_tum(Path(path), traj)


class DatasetWriters:
    """Forward every writer call to the EuRoC and/or KITTI writer chosen by ``fmt``.

    ``fmt="both"`` writes ``out_dir/euroc`` and ``out_dir/kitti``; a single format writes ``out_dir``;
    a bag format writes EuRoC into ``out_dir`` and converts it at :meth:`finalize`.
    """

    def __init__(self, out_dir, rig, metadata: dict, fmt: str = "euroc", depth: bool = False,
                 segmentation: bool = False, overwrite: bool = False, depth_format: str = "npy",
                 png: PngOptions = PngOptions(), bag_export=None):
        from sim.writers.euroc_writer import EurocWriter
        from sim.writers.kitti_writer import KittiWriter
        if fmt not in FORMATS:
            raise SimError(f"dataset format {fmt!r} unknown; valid: {', '.join(FORMATS)}")
        check_bag_export(fmt, bag_export)
        self.bag_export = bag_export
        out_dir = Path(out_dir)
        self.fmt, self.out_dir = fmt, out_dir
        self.writers = []
        if fmt in ("euroc", "both", *BAG_NAMES):
            self.writers.append(EurocWriter(out_dir / "euroc" if fmt == "both" else out_dir, rig, metadata,
                                            depth=depth, segmentation=segmentation, overwrite=overwrite,
                                            depth_format=depth_format, png=png))
        if fmt in ("kitti", "both"):
            self.writers.append(KittiWriter(out_dir / "kitti" if fmt == "both" else out_dir, rig, metadata,
                                            overwrite=overwrite, png=png))

    @property
    def resumed_frames(self) -> int:
        """Frames already complete in every writer (the caller skips this many)."""
        return min(w.resumed_frames for w in self.writers)

    def add_frame(self, t_ns, images=None, depth=None, seg=None, files_written: bool = False) -> None:
        """One stereo epoch to every writer; ``files_written``: :meth:`write_frame_files` wrote its files."""
        for w in self.writers:
            w.add_frame(t_ns, images, depth=depth, seg=seg, files_written=files_written)

    def write_frame_files(self, index: int, t_ns, images, depth=None, seg=None, timer=NO_TIMER) -> None:
        """The files of frame number ``index`` in every writer, without their rows (thread-safe); the
        frame counts once :meth:`add_frame` ``(t_ns, files_written=True)`` follows, in frame order."""
        for w in self.writers:
            w.write_frame_files(t_ns, images, depth=depth, seg=seg, index=index, timer=timer)

    def add_metadata(self, extra: dict) -> None:
        """Keys added to every ``metadata.yaml`` at :meth:`finalize` (not part of the configuration hash that
        a resumed run must match), e.g. ``rendering``: the device(s) that drew the frames."""
        for w in self.writers:
            w.extra_metadata.update(extra)

    def add_imu(self, *args, **kwargs) -> None:
        for w in self.writers:
            w.add_imu(*args, **kwargs)

    def add_groundtruth(self, *args, **kwargs) -> None:
        for w in self.writers:
            w.add_groundtruth(*args, **kwargs)

    def add_cam0_truth(self, t_ns, T_w_c0) -> None:
        for w in self.writers:
            w.add_cam0_truth(t_ns, T_w_c0)

    def add_gcps(self, gcps) -> None:
        for w in self.writers:
            w.add_gcps(gcps)

    def add_wheels(self, samples) -> None:
        """Wheel-encoder ticks (``sim.sensors.wheels.WheelSamples``) as ``wheels.csv`` in every dataset root."""
        rows = ["#timestamp [ns],left_ticks,right_ticks"]
        rows += [f"{t},{l},{r}" for t, l, r in zip(samples.t_ns, samples.left_ticks, samples.right_ticks)]
        for w in self.writers:
            atomic_write_text(w.out_dir / "wheels.csv", "\n".join(rows) + "\n")

    def add_actors(self, t_ns, actors) -> None:
        """Ground truth of a scene's moving actors as ``actors.csv`` in every dataset root: one row per frame
        time and actor, ``actors`` a list of ``(actor_id, kind, moving, T_w_x (N,4,4))`` at ``t_ns`` (N,)."""
        rows = ["#timestamp [ns],actor_id,kind,moving,p_x [m],p_y [m],p_z [m],q_w,q_x,q_y,q_z"]
        per_actor = [(a_id, kind, int(moving), T[:, :3, 3], quat_wxyz_from_R(T[:, :3, :3]))
                     for a_id, kind, moving, T in actors]
        for k, t in enumerate(np.asarray(t_ns, np.int64)):
            for a_id, kind, moving, p, q in per_actor:
                rows.append(f"{t},{a_id},{kind},{moving}," + ",".join(f"{x:.6f}" for x in (*p[k], *q[k])))
        for w in self.writers:
            atomic_write_text(w.out_dir / "actors.csv", "\n".join(rows) + "\n")

    def add_segmentation_ids(self, rows) -> None:
        """``segmentation_ids.csv`` in every dataset root: ``(seg_id, geom_name, actor_id, kind, moving)`` per
        value the segmentation PNGs hold (``seg_id`` = geom id + 1; 0 is background)."""
        lines = ["seg_id,geom_name,actor_id,kind,moving"] + [",".join(map(str, r)) for r in rows]
        for w in self.writers:
            atomic_write_text(w.out_dir / "segmentation_ids.csv", "\n".join(lines) + "\n")

    def finalize(self) -> list:
        """Finalize every writer; a bag format then converts the EuRoC folder (a bag left by an
        interrupted conversion is replaced); only then is every folder committed (metadata.yaml,
        manifest, ``INCOMPLETE`` removed), so an interruption anywhere before leaves a folder that resumes."""
        folders = [w.finalize(commit=False) for w in self.writers]
        if self.fmt in BAG_NAMES:
            import shutil
            bag = self.out_dir / BAG_NAMES[self.fmt]
            if bag.is_dir():
                shutil.rmtree(bag)
            elif bag.exists():
                bag.unlink()
            self.bag_export(self.out_dir, bag, kind=self.fmt, storage="mcap", allow_incomplete=True)
            folders.append(bag)
        for w in self.writers:
            w.commit()
        return folders
