"""The project's one exception root, and the ``rigs`` package's error.

Every error our code raises for bad input derives from :class:`TestbedError`; the command line
catches it and prints one line (exit code 2). It lives here, in the lowest package that has
errors (``rigs.geometry`` below it raises none of ours), so every package can derive from it.
"""


class TestbedError(Exception):
    """Root of every error the testbed raises for bad input; the message is one line naming the
    file, flag or field and the bad value."""

    __test__ = False        # not a pytest test class despite its name


class RigError(TestbedError, ValueError):
    """A rig, camera or IMU definition is invalid; the message names the file and the field."""


class RecordError(TestbedError):
    """A shared record is invalid (a trajectory's shapes or times) or a trajectory file is missing or
    malformed; the message names the file, the line or the field."""
