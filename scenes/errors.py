"""Exception root of the ``scenes`` package."""


class SceneError(ValueError):
    """An unknown scene name or a malformed scene file; the message names the field and valid choices."""
