"""Fan-out of writer calls to a EuRoC and/or a KITTI writer, and a TUM convenience."""
from __future__ import annotations

from pathlib import Path

from sim.errors import SimError

FORMATS = ("euroc", "kitti", "both")


def write_tum_groundtruth(path, traj) -> None:
    """Write a ``vo.trajectory.Trajectory`` as a TUM file (seconds, x y z, qx qy qz qw)."""
    from vo.trajfile import write_tum
    write_tum(Path(path), traj)


class DatasetWriters:
    """Forward every writer call to the EuRoC and/or KITTI writer chosen by ``fmt``.

    ``fmt="both"`` writes ``out_dir/euroc`` and ``out_dir/kitti``; a single format writes ``out_dir``.
    """

    def __init__(self, out_dir, rig, metadata: dict, fmt: str = "euroc", depth: bool = False,
                 segmentation: bool = False, overwrite: bool = False):
        from sim.dataset.euroc_writer import EurocWriter
        from sim.dataset.kitti_writer import KittiWriter
        if fmt not in FORMATS:
            raise SimError(f"dataset format {fmt!r} unknown; valid: {', '.join(FORMATS)}")
        out_dir = Path(out_dir)
        self.writers = []
        if fmt in ("euroc", "both"):
            self.writers.append(EurocWriter(out_dir / "euroc" if fmt == "both" else out_dir, rig, metadata,
                                            depth=depth, segmentation=segmentation, overwrite=overwrite))
        if fmt in ("kitti", "both"):
            self.writers.append(KittiWriter(out_dir / "kitti" if fmt == "both" else out_dir, rig, metadata,
                                            overwrite=overwrite))

    @property
    def resumed_frames(self) -> int:
        """Frames already complete in every writer (the caller skips this many)."""
        return min(w.resumed_frames for w in self.writers)

    def add_frame(self, t_ns, images, depth=None, seg=None) -> None:
        for w in self.writers:
            w.add_frame(t_ns, images, depth=depth, seg=seg)

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
        """Wheel-encoder ticks (``sim.wheels.WheelSamples``) as ``wheels.csv`` in every dataset root."""
        from rigs.io_yaml import write_text_atomic
        rows = ["#timestamp [ns],left_ticks,right_ticks"]
        rows += [f"{t},{l},{r}" for t, l, r in zip(samples.t_ns, samples.left_ticks, samples.right_ticks)]
        for w in self.writers:
            write_text_atomic(w.out_dir / "wheels.csv", "\n".join(rows) + "\n")

    def finalize(self) -> list:
        return [w.finalize() for w in self.writers]
