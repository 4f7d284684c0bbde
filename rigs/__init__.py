"""Camera/IMU rig definitions, presets and calibration I/O (no mujoco)."""
from rigs.errors import RigError  # noqa: F401
from rigs.model import Camera, Imu, Rig, Wheels  # noqa: F401

# Loaded on first use (PEP 562) so ``import rigs`` stays light and free of import cycles.
_LAZY = {
    "get_rig": "rigs.presets", "rig_names": "rigs.presets",
    "load_rig": "rigs.rig_yaml", "save_rig": "rigs.rig_yaml", "rig_to_dict": "rigs.rig_yaml",
    "rig_from_dict": "rigs.rig_yaml",
    "apply_overrides": "rigs.overrides",
    "get_imu_model": "rigs.imu_models", "imu_model_names": "rigs.imu_models", "IMU_MODELS": "rigs.imu_models",
    "stereo_rectify": "rigs.rectify", "Rectification": "rigs.rectify",
}


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'rigs' has no attribute {name!r}")
