"""Simulation: MuJoCo models, trajectories, rendering, sensors, ground truth, dataset writing."""
__version__ = "0.1.0"
