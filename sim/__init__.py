"""Simulation: MuJoCo models, trajectories, rendering, sensors, ground truth, dataset writing."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering unless the user chose otherwise
__version__ = "0.1.0"
