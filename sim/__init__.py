"""Simulation: MuJoCo models, trajectories, rendering, sensors, ground truth, dataset writing."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering unless the user chose otherwise
from sim.version import __version__  # noqa: F401  (the dataset version)


def stream(config=None):
    """Frames, IMU and truth in memory without writing a dataset: :func:`sim.streaming.stream`."""
    from sim.streaming import stream as _stream     # mujoco only when streaming
    return _stream(config)
