"""Exception of the ``sim`` package."""
from rigs.errors import TestbedError


class SimError(TestbedError):
    """A simulation, rendering or dataset-writing error; the message names the bad value or path."""
