"""Simulation: MuJoCo models, trajectories, rendering, sensors, ground truth, dataset writing."""
