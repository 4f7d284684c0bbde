"""Camera/IMU rig definitions, presets and calibration I/O (no mujoco)."""
from rigs.errors import RigError  # noqa: F401
from rigs.model import Camera, Imu, Rig, Wheels  # noqa: F401
