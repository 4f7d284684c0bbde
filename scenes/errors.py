"""Exception of the ``scenes`` package."""
from rigs.errors import TestbedError


class SceneError(TestbedError, ValueError):
    """An unknown scene name or a malformed scene file; the message names the field and valid choices."""
