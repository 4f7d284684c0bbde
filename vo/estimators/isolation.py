"""Where an external program (``cmd:...``) runs: a clean environment, and a private file-system view when the
machine has a namespace tool.

Two modes (``Isolation.mode``):

- ``namespace``: the program runs in new mount and PID namespaces, built by an existing tool, bubblewrap
  (``bwrap``) when installed, otherwise util-linux ``unshare`` (as root; the mounts are ``mount`` calls in a
  few lines of ``sh`` inside the namespace). It sees only the system's own folders (``/usr``, ``/bin``, ``/lib*``,
  ``/etc``, ``/opt``: read-only), a few device nodes, a private ``/proc`` (its own processes only: it is PID 1)
  and ``/tmp``, the sensor view (read-only), its output folder, and its own files (its executable's
  installation or virtual environment, and every existing path written in the template): read-only. The
  scenario cache and the dataset folder are covered by an empty ``tmpfs`` where they lie inside one of those
  folders. Under ``unshare`` the program itself then runs in a new user namespace (root there, without
  privileges outside), so it cannot undo a mount or make the read-only ones writable.
- ``view only``: no namespace tool works here; the program runs as a normal process and sees the whole
  machine. It still gets the sensor-only view (copies, verified by hash) and a clean environment.

The environment (both modes) is an allow-list (:data:`KEEP_ENV`): nothing that names the dataset, the cache or
this tool's configuration reaches the program; ``HOME`` and the working folder are its (empty) output folder.
"""
from __future__ import annotations

import functools
import os
import shlex
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from vo.errors import EstimatorError

MODES = ("auto", "required", "view-only")
NAMESPACE, VIEW_ONLY = "namespace", "view only"
KEEP_ENV = ("PATH", "LANG", "LANGUAGE", "TZ", "TERM")      # and every LC_*
SYSTEM_DIRS = ("/usr", "/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32", "/etc", "/opt")
DEVICES = ("null", "zero", "full", "random", "urandom")


def clean_env(home: Path, tmp: str) -> dict:
    """The program's environment: locale, ``PATH`` and terminal type from ours; ``HOME``/``PWD`` its output
    folder, ``TMPDIR`` ``tmp``; nothing else (no ``VO_TESTBED_*``, ``OLDPWD``, ``PYTHONPATH`` ...)."""
    env = {k: v for k, v in os.environ.items() if k in KEEP_ENV or k.startswith("LC_")}
    env.setdefault("PATH", os.defpath)
    env.update(HOME=str(home), PWD=str(home), TMPDIR=tmp)
    return env


@dataclass(frozen=True)
class Plan:
    """What one run mounts: ``view`` (read-only), ``out`` (writable, also the working folder), ``own``
    (the program's own files, read-only), ``hidden`` (folders covered by an empty tmpfs when inside ``own``)."""

    view: Path
    out: Path
    own: tuple = ()
    hidden: tuple = ()
    root: Path = field(default=Path("/nonexistent"))       # an empty folder: the mount point of the new root


class Isolation:
    """``Isolation(mode)``: ``mode`` one of :data:`MODES`; ``.used`` is ``"namespace"`` or ``"view only"``;
    ``wrap(argv, plan)`` -> the argument list that runs ``argv`` so."""

    def __init__(self, mode: str = "auto"):
        if mode not in MODES:
            raise EstimatorError(f"isolation: {mode!r} unknown; valid: {', '.join(MODES)}")
        self.tool, why = (None, "view-only asked for") if mode == "view-only" else available_tool()
        if mode == "required" and self.tool is None:
            raise EstimatorError(f"--isolation required: no namespace isolation on this machine ({why}); "
                                 f"install bubblewrap (bwrap), or run as root where util-linux unshare works")
        self.why = why
        self.used = NAMESPACE if self.tool else VIEW_ONLY

    def wrap(self, argv: list, plan: Plan) -> list:
        if self.tool == "bwrap":
            return bwrap_argv(argv, plan)
        if self.tool == "unshare":
            return unshare_argv(argv, plan)
        return list(argv)


@functools.lru_cache(maxsize=None)
def available_tool() -> tuple:
    """``("bwrap" | "unshare" | None, reason)``: the first tool that runs ``true`` in a full namespace here."""
    reasons = []
    for tool, build in (("bwrap", bwrap_argv), ("unshare", unshare_argv)):
        if shutil.which(tool) is None:
            reasons.append(f"no {tool}")
            continue
        if tool == "unshare" and os.geteuid() != 0:
            reasons.append("unshare needs root to mount a private /proc")
            continue
        with tempfile.TemporaryDirectory(prefix="vo_probe_") as tmp:
            plan = _probe_plan(Path(tmp))
            try:
                p = subprocess.run(build(["/bin/sh", "-c", "test -r /proc/1/cmdline && test ! -e /root/.cache"],
                                         plan), capture_output=True, text=True, timeout=30,
                                   env=clean_env(plan.out, "/tmp"), cwd=plan.out)
            except (OSError, subprocess.TimeoutExpired) as e:
                reasons.append(f"{tool}: {e}")
                continue
        if p.returncode == 0:
            return tool, f"{tool} works"
        last = next((ln for ln in reversed(p.stderr.splitlines()) if ln.strip()), f"exit {p.returncode}")
        reasons.append(f"{tool}: {last.strip()}")
    return None, "; ".join(reasons)


def _probe_plan(tmp: Path) -> Plan:
    for name in ("view", "out", "root"):
        (tmp / name).mkdir()
    return Plan(tmp / "view", tmp / "out", root=tmp / "root")


def own_paths(argv: list, cwd: Path) -> tuple:
    """Folders a program needs besides the system's: the installation of its executable (the parent of its
    ``bin/``, or of a version manager's ``shims/``; a virtual environment and its base Python), and the folder
    of every existing path among its arguments. Each as named (absolute) and, when a symbolic link leads
    elsewhere, also where it leads."""
    out = []
    exe = shutil.which(argv[0]) if argv else None
    if exe:
        for p in {Path(os.path.abspath(exe)), Path(os.path.realpath(exe))}:
            prefix = p.parent.parent if p.parent.name in ("bin", "shims") else p.parent   # shims: pyenv, asdf
            out.append(prefix)
            home = _venv_home(prefix)
            if home is not None:
                out.append(home.parent if home.name == "bin" else home)
    for a in argv[1:]:
        p = Path(a) if os.path.isabs(a) else cwd / a
        if a and p.exists():
            out.append(p if p.is_dir() else p.parent)
    named = [Path(os.path.abspath(p)) for p in out]
    both = [q for p in named for q in (p, Path(os.path.realpath(p)))]
    return tuple(dict.fromkeys(p for p in both if not _is_system(Path(os.path.realpath(p)))))


def _venv_home(prefix: Path):
    cfg = prefix / "pyvenv.cfg"
    if not cfg.is_file():
        return None
    for line in cfg.read_text(errors="replace").splitlines():
        key, _, value = line.partition("=")
        if key.strip() == "home" and value.strip():
            return Path(value.strip())
    return None


def _is_system(p: Path) -> bool:
    return str(p) == "/" or any(str(p) == d or str(p).startswith(d + "/") for d in SYSTEM_DIRS)


def _inside(p: Path, folder: Path) -> bool:
    return p == folder or folder in p.parents


def hidden_within(own: tuple, protect: tuple) -> tuple:
    """Where to cover the folders of ``protect`` (the dataset, the cache) with an empty tmpfs: every place they
    appear inside one of ``own`` or of the system folders (as each is bound, so also through a symbolic link).
    A protected folder that contains one of ``own`` is refused: the program would run from inside the dataset
    or the cache."""
    system = [Path(d) for d, kind, _ in _system_entries() if kind == "dir"]
    hidden = []
    for p in (Path(os.path.realpath(x)) for x in protect):
        for folder in list(own) + system:
            real = Path(os.path.realpath(folder))
            if folder in own and _inside(real, p):
                raise EstimatorError(f"{folder}: the program's files lie inside {p} (the dataset or the scenario "
                                     f"cache); move them elsewhere")
            if _inside(p, real):
                hidden.append(Path(folder) / p.relative_to(real))
    return tuple(dict.fromkeys(hidden))


def _system_entries():
    for d in SYSTEM_DIRS:
        if os.path.islink(d):
            yield d, "link", os.readlink(d)
        elif os.path.isdir(d):
            yield d, "dir", None


def bwrap_argv(argv: list, plan: Plan) -> list:
    """bubblewrap: new user, mount, PID, IPC and UTS namespaces; dies with us."""
    a = ["bwrap", "--unshare-user", "--unshare-pid", "--unshare-ipc", "--unshare-uts", "--die-with-parent",
         "--tmpfs", "/"]
    for d, kind, target in _system_entries():
        a += ["--symlink", target, d] if kind == "link" else ["--ro-bind", d, d]
    a += ["--dev", "/dev", "--proc", "/proc", "--tmpfs", "/tmp"]
    for p in plan.own:
        a += ["--ro-bind", str(p), str(p)]
    for p in plan.hidden:
        a += ["--tmpfs", str(p), "--remount-ro", str(p)]
    a += ["--ro-bind", str(plan.view), str(plan.view), "--bind", str(plan.out), str(plan.out),
          "--chdir", str(plan.out), "--"]
    return a + list(argv)


def unshare_argv(argv: list, plan: Plan) -> list:
    """util-linux ``unshare`` (as root): new mount and PID namespaces (killed with us: ``--kill-child``); inside,
    ``sh`` mounts a tmpfs root with the bind mounts of :class:`Plan` and a new ``/proc``, then a second
    ``unshare`` enters a user namespace, changes root to it and runs the program."""
    q = shlex.quote
    r = str(plan.root)
    lines = ["set -e", f"R={q(r)}", 'mount -t tmpfs -o mode=0755 vo-root "$R"']

    def ro_bind(src, dst_is_file=False):
        d = q(str(src))
        make = f'mkdir -p "$(dirname "$R"{d})" && touch "$R"{d}' if dst_is_file else f'mkdir -p "$R"{d}'
        return [make, f'mount --bind {d} "$R"{d}', f'mount -o remount,bind,ro "$R"{d}']

    for d, kind, target in _system_entries():
        lines += [f'ln -s {q(target)} "$R"{q(d)}'] if kind == "link" else ro_bind(d)
    lines += ['mkdir -p "$R/proc" "$R/tmp" "$R/dev/shm"', 'mount -t proc -o nosuid,nodev,noexec proc "$R/proc"',
              'mount -t tmpfs -o mode=1777 vo-tmp "$R/tmp"', 'mount -t tmpfs -o mode=1777 vo-shm "$R/dev/shm"']
    for dev in DEVICES:
        if os.path.exists(f"/dev/{dev}"):
            lines += [f'touch "$R/dev/{dev}"', f'mount --bind /dev/{dev} "$R/dev/{dev}"']
    lines += ['ln -s /proc/self/fd "$R/dev/fd"'] + [f'ln -s /proc/self/fd/{i} "$R/dev/{n}"'
                                                     for i, n in enumerate(("stdin", "stdout", "stderr"))]
    for p in plan.own:
        lines += ro_bind(p)
    for p in plan.hidden:
        lines += [f'mount -t tmpfs -o ro,mode=0555 vo-hidden "$R"{q(str(p))}']
    lines += ro_bind(plan.view)
    lines += [f'mkdir -p "$R"{q(str(plan.out))}', f'mount --bind {q(str(plan.out))} "$R"{q(str(plan.out))}',
              f'exec unshare --user --map-root-user --root="$R" --wd={q(str(plan.out))} -- "$@"']
    return ["unshare", "--mount", "--pid", "--fork", "--kill-child", "--propagation", "private", "--",
            "/bin/sh", "-c", "\n".join(lines), "vo-isolate"] + list(argv)
