"""Exception root of the ``sim`` package."""


class SimError(Exception):
    """A simulation, rendering or dataset-writing error; the message names the bad value or path."""
