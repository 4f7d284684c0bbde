"""Simulation: MuJoCo models, trajectories, rendering, sensors, ground truth, dataset writing."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering unless the user chose otherwise
__version__ = "0.3.0"      # dataset version (metadata, config hash): bumped when a config's bytes change
