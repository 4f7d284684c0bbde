"""Front-ends: grey conversion, KLT (seed 003) and descriptor (ORB / SIFT) correspondences, grid, stereo geometry."""
from vo.frontend.correspondences import correspondences  # noqa: F401
from vo.frontend.grid import Grid  # noqa: F401
from vo.frontend.klt import KltConfig, KltTracker, is_keyframe, track_fb  # noqa: F401
