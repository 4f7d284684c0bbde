"""External estimators (``cmd:<template>``): run a program on a sensor-only view of a dataset, read its trajectory.

The program gets, as ``{dataset}``, a read-only folder of sensor data (:mod:`vo.estimators.sensor_view`), and
as ``{out}`` the file to write its TUM trajectory of ``T_o_c0`` to; it runs with a clean environment, in its
own (empty) working folder, isolated by namespaces where the machine allows it (:mod:`vo.estimators.isolation`).

Process control: the program runs in a new session (its own process group). When it runs longer than the
timeout (default :func:`default_timeout_s`: 20 x the sequence's duration + 60 s), or when we are interrupted
(Ctrl-C), the whole group is ended (SIGTERM, then SIGKILL 2 s later); the group is also ended when the program
exits, so no child it started outlives it; SIGTERM to us (a cancelled CI job) does the same (exit 143). If we
are killed outright, ``setpriv --pdeathsig`` (util-linux) kills the program. Under namespace isolation the
program runs in its own PID namespace: every process it started ends with it, even one that left the group.
Only the last :data:`TAIL_BYTES` of its stderr (and of its stdout) are kept.

Templates: ``{dataset}`` and ``{out}`` are the only fields; literal braces are written ``{{`` and ``}}``. The
template is split like a shell command line (``shlex``) and run without a shell.
"""
from __future__ import annotations

import contextlib
import os
import shlex
import shutil
import signal
import string
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path

from rigs.trajectory import Trajectory
from rigs.trajfile import read_tum
from vo.dataset import open_dataset
from vo.errors import EstimatorError, VoError
from vo.estimators.isolation import Isolation, Plan, clean_env, hidden_within, own_paths
from vo.estimators.sensor_view import SensorView

FIELDS = ("dataset", "out")
TAIL_BYTES = 64 * 1024
KILL_GRACE_S = 2.0


class ExternalCommandError(EstimatorError):
    """An external program failed; ``stderr`` holds (the tail of) what it printed there."""

    def __init__(self, message: str, stderr: str = ""):
        super().__init__(message)
        self.stderr = stderr


def default_timeout_s(duration_s: float) -> float:
    """The default limit for one run on a sequence of ``duration_s`` seconds: 20 x duration + 60 s."""
    return 20.0 * max(float(duration_s), 0.0) + 60.0


class ExternalCommand:
    """An external VO program: ``cmd_template`` holds ``{dataset}`` and ``{out}``, e.g.
    ``"my_vo --data {dataset} --traj {out}"``; the program must write a TUM trajectory of ``T_o_c0`` to ``{out}``.

    A template with another field, a lone brace, or an unbalanced quote raises EstimatorError (exit code 2)."""

    def __init__(self, cmd_template: str, timeout_s: float | None = None):
        if cmd_template.startswith("cmd:"):
            cmd_template = cmd_template[4:]
        self.cmd_template, self.timeout_s = cmd_template.strip(), timeout_s
        try:
            self.args = shlex.split(self.cmd_template)
        except ValueError as e:
            raise EstimatorError(f"external command {self.cmd_template!r}: cannot split it into arguments "
                                 f"({e})") from None
        found = set()
        for arg in self.args:
            try:
                names = [f for _, f, _, _ in string.Formatter().parse(arg) if f is not None]
            except ValueError as e:
                raise EstimatorError(f"external command {self.cmd_template!r}: {e} in {arg!r}; write literal "
                                     f"braces as {{{{ and }}}}") from None
            bad = [n for n in names if n not in FIELDS]
            if bad:
                raise EstimatorError(f"external command {self.cmd_template!r}: unknown field {{{bad[0]}}}; the "
                                     f"fields are {{dataset}} and {{out}}; write literal braces as {{{{ and }}}}")
            found.update(names)
        for key in FIELDS:
            if key not in found:
                raise EstimatorError(f"external command {self.cmd_template!r}: template must contain {{{key}}} "
                                     f"(and {{dataset}}, {{out}})")
        self.name = "cmd:" + (self.args or ["?"])[0]
        self.stderr = self.stdout = ""

    def check_program(self) -> None:
        """Raise EstimatorError when the program (the template's first word) is not found (on ``PATH``, or
        relative to the current folder)."""
        first = self._absolute(self.args[0]) if self.args else ""
        if not first or shutil.which(first) is None:
            raise EstimatorError(f"external command {self.cmd_template!r}: program not found "
                                 f"({first or 'empty template'})")

    def command(self, dataset_path, out_path) -> list:
        """The argument list for one run."""
        return [a.format(dataset=str(dataset_path), out=str(out_path)) for a in self.args]

    def run(self, dataset_path, out_path, isolation: Isolation | None = None, protect=(), cwd=None) -> Path:
        """Run once -> ``out_path``. ``protect``: folders the program must not see (covered under namespace
        isolation). The working folder and ``HOME`` are ``cwd`` (default: the folder of ``out_path``).
        Failure, timeout -> ExternalCommandError naming it (the tail of stderr in ``.stderr``)."""
        isolation = isolation or Isolation("auto")
        out_path = Path(out_path)
        home = Path(cwd) if cwd is not None else out_path.parent
        argv = [self._absolute(a) for a in self.command(dataset_path, out_path)]
        self.check_program()
        plan = Plan(Path(dataset_path), home)
        if isolation.tool:
            own = own_paths(argv, Path.cwd())
            plan = replace(plan, own=own, hidden=hidden_within(own, protect),
                           root=Path(tempfile.mkdtemp(prefix="vo_root_")))
        tmp = "/tmp" if isolation.tool else str(home)
        self.stderr = self.stdout = ""
        try:
            rc = self._supervise(isolation.wrap(argv, plan), clean_env(home, tmp), home)
        except FileNotFoundError as e:
            raise EstimatorError(f"external command {self.cmd_template!r}: program not found ({e.filename})") from None
        finally:
            if isolation.tool:
                shutil.rmtree(plan.root, ignore_errors=True)      # an empty mount point on our side
        if rc is None:
            raise ExternalCommandError(f"external command {self.cmd_template!r}: timed out after "
                                       f"{self.timeout_s:g} s (--timeout); its process group was ended", self.stderr)
        if rc != 0:
            last = next((ln for ln in reversed(self.stderr.splitlines()) if ln.strip()), "")
            where = (" (under namespace isolation it sees only the system folders, its input, its output folder and "
                     "its own files: its installation and the paths in its template)") if isolation.tool else ""
            raise ExternalCommandError(f"external command {self.cmd_template!r} failed with exit code "
                                       f"{rc}: {last}{where}", self.stderr)
        if not out_path.is_file():
            raise ExternalCommandError(f"external command {self.cmd_template!r}: exit 0 but wrote no trajectory "
                                       f"to {{out}}", self.stderr)
        return out_path

    def _absolute(self, arg: str) -> str:
        """A relative path that exists from our working folder, made absolute (the program runs elsewhere)."""
        return str(Path(arg).absolute()) if arg and not os.path.isabs(arg) and os.path.exists(arg) else arg

    def _supervise(self, argv: list, env: dict, cwd: Path):
        """Run ``argv`` in a new session -> its exit code, or None on timeout. The group is ended on timeout,
        on any exception here (KeyboardInterrupt included), and after the program exits."""
        if shutil.which("setpriv"):                 # util-linux: the program is killed if we die (even SIGKILL)
            argv = ["setpriv", "--pdeathsig", "KILL", "--"] + list(argv)
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                env=env, cwd=cwd, start_new_session=True)
        tails = [_Tail(proc.stdout), _Tail(proc.stderr)]
        try:
            with _sigterm_as_exit():
                rc = proc.wait(timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            rc = None
        finally:
            _end_group(proc)
            for t in tails:
                t.join()
            self.stdout, self.stderr = (t.text() for t in tails)
            for t in tails:
                if not t.is_alive():          # one still reading: a process that left the group holds the pipe
                    t.pipe.close()
        return rc


class _Tail(threading.Thread):
    """Read a pipe to its end, keeping the last :data:`TAIL_BYTES`."""

    def __init__(self, pipe):
        super().__init__(daemon=True)
        self.pipe, self.buf, self.cut = pipe, bytearray(), False
        self.start()

    def run(self):
        for block in iter(lambda: self.pipe.read1(65536), b""):
            self.buf += block
            if len(self.buf) > 2 * TAIL_BYTES:
                del self.buf[:-TAIL_BYTES]
                self.cut = True

    def join(self, timeout=5.0):
        super().join(timeout)

    def text(self) -> str:
        body = bytes(self.buf[-TAIL_BYTES:]).decode("utf-8", errors="replace")
        return ("[... earlier output cut; the last 64 KiB follow]\n" + body) if self.cut or len(self.buf) > TAIL_BYTES \
            else body


@contextlib.contextmanager
def _sigterm_as_exit():
    """While the program runs, SIGTERM (a cancelled CI job) exits with 143 through ``finally`` blocks, so the
    program's group is ended as on Ctrl-C (the main thread only: Python's signal handlers live there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def exit_143(signum, frame):
        raise SystemExit(128 + signum)
    old = signal.signal(signal.SIGTERM, exit_143)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _end_group(proc: subprocess.Popen) -> None:
    """SIGTERM to the program's process group, SIGKILL to what is left after :data:`KILL_GRACE_S`; reap it."""
    _signal_group(proc.pid, signal.SIGTERM)
    deadline = time.monotonic() + KILL_GRACE_S
    while time.monotonic() < deadline and (proc.poll() is None or _group_alive(proc.pid)):
        time.sleep(0.02)
    _signal_group(proc.pid, signal.SIGKILL)
    proc.wait()


def _signal_group(pgid: int, sig) -> None:
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except (ProcessLookupError, PermissionError):
        return False


@dataclass
class ExternalRun:
    """What one external run gave: ``trajectory`` (T_o_c0), its wall time, the tail of its stderr, and the
    isolation it ran under (``"namespace"`` or ``"view only"``)."""

    name: str
    trajectory: Trajectory
    wall_time_s: float
    stderr: str
    isolation: str


def run_external(spec: str, dataset, timeout_s: float | None = None, isolation: str = "auto") -> ExternalRun:
    """Run ``cmd:...`` on a sensor-only view of ``dataset`` (an opened Dataset or a folder to open): the program
    never sees ground truth, cannot change the dataset, and is ended after ``timeout_s`` (None: the default
    of :func:`default_timeout_s` for this sequence)."""
    ds = open_dataset(dataset) if isinstance(dataset, (str, Path)) else dataset
    if getattr(ds, "path", None) is None:
        raise EstimatorError(f"{spec}: external commands need a dataset folder (dataset.path)")
    if timeout_s is None:
        t = ds.frame_times_ns
        timeout_s = default_timeout_s((int(t[-1]) - int(t[0])) * 1e-9 if len(t) else 0.0)
    if not (timeout_s > 0):
        raise EstimatorError(f"--timeout: must be > 0 s, got {timeout_s!r}")
    iso = Isolation(isolation)
    cmd = ExternalCommand(spec, timeout_s=timeout_s)
    protect = tuple(p for p in {Path(getattr(ds, "root", ds.path)), Path(ds.path), *_cache_roots()} if p.is_dir())
    t0 = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="vo_ext_"))
    try:
        (work / "out").mkdir()
        sensors = SensorView(ds, work / "sensors")
        with sensors as view:
            try:
                out = cmd.run(view, work / "out" / "trajectory_tum.txt", iso, protect)
            finally:
                try:
                    sensors.check_untouched(cmd.name)      # also after a crash: a changed input is worse
                except EstimatorError as e:
                    raise ExternalCommandError(str(e), cmd.stderr) from None
            try:
                traj = read_tum(out, ref="o", frame="c0")
            except VoError as e:
                raise ExternalCommandError(f"{cmd.name}: unreadable TUM output ({e})", cmd.stderr) from None
    finally:
        _remove_tree(work)
    return ExternalRun(cmd.name, traj, time.perf_counter() - t0, cmd.stderr, iso.used)


def _cache_roots() -> list:
    """The scenario cache (``VO_TESTBED_CACHE``, default ``~/.cache/vo-testbed``): never shown to a program."""
    root = os.environ.get("VO_TESTBED_CACHE")
    return [Path(root)] if root else [Path.home() / ".cache" / "vo-testbed"]


def _remove_tree(folder: Path) -> None:
    for d, _, _ in os.walk(folder):
        try:
            os.chmod(d, 0o755)
        except OSError:
            pass
    shutil.rmtree(folder, ignore_errors=True)
