# compat re-export: removed at merge (trajectory files live in rigs.trajfile)
from rigs.trajfile import (  # noqa: F401
    write_tum,
    tum_times_ns,
    read_tum,
    write_kitti,
    kitti_times_path,
    read_kitti_times,
    read_kitti,
    read_euroc_groundtruth,
    detect_format,
    read_trajectory,
    LOG,
    NS_MIN_MAGNITUDE,
    NS_MIN_STEP,
    QUAT_MIN_NORM,
    AUTO_COLUMNS,
    Trajectory,
)

__all__ = ['write_tum', 'tum_times_ns', 'read_tum', 'write_kitti', 'kitti_times_path', 'read_kitti_times', 'read_kitti', 'read_euroc_groundtruth', 'detect_format', 'read_trajectory', 'LOG', 'NS_MIN_MAGNITUDE', 'NS_MIN_STEP', 'QUAT_MIN_NORM', 'AUTO_COLUMNS', 'Trajectory']
