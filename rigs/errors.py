"""Exception root of the ``rigs`` package."""


class RigError(ValueError):
    """A rig, camera or IMU definition is invalid; the message names the file and the field."""
