"""Rover dead reckoning: an EKF (filterpy) fusing IMU attitude and wheel odometry (seed 001 §1: the
on-board GNC dead reckoning whose error the cross-site localization corrects)."""
from vo.deadreckoning.ekf import DeadReckoning, DeadReckoningConfig, dead_reckon  # noqa: F401
