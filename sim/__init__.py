"""Simulation: MuJoCo models, trajectories, rendering, sensors, ground truth, dataset writing."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering unless the user chose otherwise
__version__ = "0.3.0"      # dataset version (metadata, config hash): bumped when a config's bytes change


def stream(config=None):
    """Frames, IMU and truth in memory without writing a dataset: :func:`sim.streaming.stream`."""
    from sim.streaming import stream as _stream     # mujoco only when streaming
    return _stream(config)
