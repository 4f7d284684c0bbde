"""Start a program under test as a shell starts a foreground command: SIGINT at its default action.

A suite started as a background job (``cmd &``, ``nohup``) inherits SIGINT ignored, and every process it starts
inherits that too; a Python program then never sees Ctrl-C (it installs its handler only over the default action).
The tests that send SIGINT start their program with ``preexec_fn=foreground_sigint``."""
import signal


def foreground_sigint() -> None:
    """``preexec_fn`` of :class:`subprocess.Popen`: SIGINT back to its default action in the child."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
