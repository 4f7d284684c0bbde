"""Dataset writers (EuRoC ASL, KITTI odometry, ROS bags); they take numpy arrays and never import mujoco."""
from pathlib import Path

from sim.writers.euroc_writer import EurocWriter, euroc_resume_state  # noqa: F401
from sim.writers.fanout import DatasetWriters, write_tum_groundtruth  # noqa: F401
from sim.writers.kitti_writer import KittiWriter, kitti_resume_state  # noqa: F401


def resume_state(out_dir) -> int:
    """Frames already fully written in an (incomplete) dataset folder (EuRoC or KITTI layout)."""
    out_dir = Path(out_dir)
    if (out_dir / "mav0").is_dir():
        return euroc_resume_state(out_dir)
    if (out_dir / "kitti_frames.csv").exists():
        return kitti_resume_state(out_dir)
    return 0


__all__ = ["EurocWriter", "KittiWriter", "DatasetWriters", "write_tum_groundtruth", "resume_state",
           "euroc_resume_state", "kitti_resume_state"]
