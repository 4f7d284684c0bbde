"""`vo-testbed check` against a program that tries to read the answer, change its input, hang, or leave
children behind; and in-process plug-ins that would read the truth. Real processes throughout: `check` runs as
its own process (so the program's parent is a real `check` command line, with `VO_TESTBED_CACHE` set).

Isolation here: the program finds nothing under namespace isolation (bubblewrap or util-linux unshare); where no
namespace tool works the namespace part is skipped, saying why.
"""
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from foreground import foreground_sigint
from vo.estimators.base import Estimator, FrameResult
from vo.estimators.isolation import available_tool

REPO = Path(__file__).resolve().parents[1]
NAMESPACE_TOOL, WHY_NOT = available_tool()
pytestmark = pytest.mark.slow                  # each test starts `check` as its own process (3-16 s)
needs_namespace = pytest.mark.skipif(NAMESPACE_TOOL is None, reason=f"no namespace isolation here: {WHY_NOT}")

HOSTILE = r'''
import glob, json, os, sys
ds, out = sys.argv[1], sys.argv[2]
report = {"env": [], "proc": [], "truth": None, "wrote_view": False, "pid": os.getpid()}
CACHE = __CACHE__                                    # a guess a program could make (~/.cache/vo-testbed ...)
for k, v in os.environ.items():
    if k.startswith("VO_TESTBED") or "vo-cache" in v or k in ("OLDPWD", "PYTHONPATH"):
        report["env"].append(k)
candidates = [CACHE, os.path.expanduser("~/.cache/vo-testbed")]
for pid in ["self", str(os.getppid())] + [p for p in os.listdir("/proc") if p.isdigit()]:
    for what in ("cmdline", "environ"):
        try:
            text = open(f"/proc/{pid}/{what}", "rb").read().decode(errors="replace")
        except OSError:
            continue
        for tok in text.replace("\0", " ").replace("=", " ").split():
            if "vo-cache" in tok or tok.startswith("check"):
                report["proc"].append(f"{pid}/{what}: {tok}")
                if os.path.isabs(tok):
                    candidates.append(tok)
up = os.path.dirname(ds)                              # the folders above the view
while up not in ("", "/"):
    candidates.append(up)
    up = os.path.dirname(up)
for c in candidates:
    hits = glob.glob(os.path.join(c, "groundtruth_tum.txt")) + glob.glob(os.path.join(c, "*", "groundtruth_tum.txt"))
    if hits:
        report["truth"] = hits[0]
        break
csv = os.path.join(ds, "mav0", "imu0", "data.csv")  # change the input and hide it: restore the mtime
st = os.stat(csv)
try:
    os.chmod(csv, 0o644)
    with open(csv, "r+b") as f:
        f.seek(-2, 2)
        f.write(b"9\n")
    os.utime(csv, ns=(st.st_atime_ns, st.st_mtime_ns))
    report["wrote_view"] = True
except OSError as e:
    report["write_error"] = str(e)
if report["truth"]:
    open(out, "w").write(open(report["truth"]).read())
else:                                                 # no answer: stand still at every frame time
    times = [l.split(",")[0] for l in open(os.path.join(ds, "mav0", "cam0", "data.csv")) if l[0].isdigit()]
    open(out, "w").writelines(f"{int(t) / 1e9:.9f} 0 0 0 0 0 0 1\n" for t in times)
print("REPORT " + json.dumps(report), file=sys.stderr)
'''


@pytest.fixture
def cache(tmp_path_factory):
    root = tmp_path_factory.getbasetemp() / "vo-cache"      # shared with the other check tests
    from sim.app.check import scenario_dataset
    old = os.environ.get("VO_TESTBED_CACHE")
    os.environ["VO_TESTBED_CACHE"] = str(root)
    try:
        path = scenario_dataset("smoke", progress=False)
    finally:
        if old is None:
            del os.environ["VO_TESTBED_CACHE"]
        else:
            os.environ["VO_TESTBED_CACHE"] = old
    return root, path


def check_process(cache_root, *args, path_env=None, wait=True, timeout=300):
    """`vo-testbed check --scenario smoke ...` as its own process -> CompletedProcess (or Popen, wait=False)."""
    env = dict(os.environ, VO_TESTBED_CACHE=str(cache_root), PYTHONPATH=f"{REPO}{os.pathsep}{REPO / 'tests'}",
               MUJOCO_GL="egl")
    if path_env is not None:
        env["PATH"] = path_env
    argv = [sys.executable, "-c", "from sim.app.cli import main; main()", "check", "--scenario", "smoke",
            "--no-progress", *args]
    if not wait:
        return subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                preexec_fn=foreground_sigint)
    return subprocess.run(argv, env=env, capture_output=True, text=True, timeout=timeout)


def hostile(tmp_path, cache_root):
    script = tmp_path / "hostile.py"
    script.write_text(HOSTILE.replace("__CACHE__", repr(str(cache_root))))
    return f"cmd:{sys.executable} {script} {{dataset}} {{out}}"


def report_of(text):
    line = next(ln for ln in text.splitlines() if "REPORT " in ln)
    return json.loads(line.split("REPORT ", 1)[1])


def digest(folder: Path) -> dict:
    import hashlib
    return {str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


@needs_namespace
def test_hostile_program_finds_nothing_under_namespace_isolation(cache, tmp_path):
    root, path = cache
    before = digest(path)
    r = check_process(root, "--estimator", hostile(tmp_path, root), "--max-ate", "0.001",
                      "--isolation", "required", "--json")
    assert r.returncode == 1, r.stdout + r.stderr                 # the gate fails: no answer was found
    res = json.loads(r.stdout)
    assert res["isolation"] == "namespace" and res["figures"]["max_ate"] > 0.001
    rep = report_of(res["program_stderr"])
    assert rep == {**rep, "env": [], "proc": [], "truth": None, "wrote_view": False}, rep
    assert rep["pid"] <= 2                                        # its own PID namespace (bwrap's init is 1)
    assert "Read-only file system" in rep["write_error"]
    assert digest(path) == before                                 # the cache: same bytes, same mtimes


def test_hostile_program_without_namespaces_is_caught_changing_its_input(cache, tmp_path):
    """``view only``: the environment is clean, but a program that searches the machine finds the parent's
    environment in /proc and the cache: the docs say so. Its change to the input is caught by hash."""
    root, path = cache
    before = digest(path)
    r = check_process(root, "--estimator", hostile(tmp_path, root), "--max-ate", "0.001", "--isolation", "view-only")
    assert r.returncode == 2, r.stdout + r.stderr
    assert "changed the sensor file mav0/imu0/data.csv" in r.stderr and "Traceback" not in r.stderr
    rep = report_of(r.stderr)                                     # the program's stderr is shown
    assert rep["env"] == [] and rep["wrote_view"] and rep["pid"] != 1
    assert digest(path) == before                                 # a copy was changed, never the cache


def test_isolation_required_refuses_where_no_namespace_tool_works(cache, tmp_path):
    root, _ = cache
    bare = tmp_path / "bin"                                       # a PATH with python only: no bwrap, no unshare
    bare.mkdir()
    (bare / "python3").symlink_to(sys.executable)
    spec = f"cmd:python3 {tmp_path / 'x.py'} {{dataset}} {{out}}"
    (tmp_path / "x.py").write_text("import shutil, sys\nopen(sys.argv[2], 'w').write('1 0 0 0 0 0 0 1\\n')\n")
    r = check_process(root, "--estimator", spec, "--max-ate", "1", "--isolation", "required", path_env=str(bare))
    assert r.returncode == 2 and "--isolation required: no namespace isolation" in r.stderr, r.stderr
    r = check_process(root, "--estimator", spec, "--max-ate", "1", path_env=str(bare))
    assert r.returncode == 1 and re.search(r"isolation +view only", r.stdout), r.stdout + r.stderr


def marker_processes(marker):
    found = []
    for pid in os.listdir("/proc"):
        try:
            if pid.isdigit() and marker.encode() in open(f"/proc/{pid}/cmdline", "rb").read():
                found.append(int(pid))
        except OSError:
            pass
    return found


def spawner(tmp_path, marker, then="time.sleep(3600)"):
    """A program that starts a child sleeping for an hour (its command line carries ``marker``), then hangs."""
    script = tmp_path / "spawner.py"
    script.write_text("import subprocess, sys, time\n"
                      f"subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(3600)', {marker!r}])\n"
                      f"print('child started', file=sys.stderr, flush=True)\n{then}\n")
    return f"cmd:{sys.executable} {script} {{dataset}} {{out}}"


def wait_gone(marker, seconds=10.0):
    deadline = time.monotonic() + seconds
    while marker_processes(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    return marker_processes(marker)


@pytest.mark.parametrize("isolation", ["auto", "view-only"])
def test_timeout_ends_the_program_and_its_child(cache, tmp_path, isolation):
    root, _ = cache
    marker = f"vo-timeout-child-{os.getpid()}-{isolation}"
    t0 = time.monotonic()
    r = check_process(root, "--estimator", spawner(tmp_path, marker), "--max-ate", "1", "--timeout", "3",
                      "--isolation", isolation)
    assert r.returncode == 2 and "timed out after 3 s (--timeout)" in r.stderr, r.stderr
    assert "child started" in r.stderr                            # the program did start its child
    assert time.monotonic() - t0 < 60
    assert wait_gone(marker) == []                                # no orphan


@pytest.mark.parametrize("isolation, sig, code", [("auto", signal.SIGINT, 130), ("view-only", signal.SIGINT, 130),
                                                   ("auto", signal.SIGTERM, 143),
                                                   pytest.param("auto", signal.SIGKILL, -9, marks=needs_namespace)])
def test_ctrl_c_ends_the_program_and_its_child(cache, tmp_path, isolation, sig, code):
    """Ctrl-C (SIGINT), a cancelled CI job (SIGTERM), and under namespace isolation even SIGKILL to `check` end the
    program and the child it started."""
    root, _ = cache
    marker = f"vo-sig{int(sig)}-child-{os.getpid()}-{isolation}"
    proc = check_process(root, "--estimator", spawner(tmp_path, marker), "--max-ate", "1", "--isolation", isolation,
                         wait=False)
    try:
        deadline = time.monotonic() + 60
        while not marker_processes(marker) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert marker_processes(marker), "the program's child never started"
        proc.send_signal(sig)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == code
    assert wait_gone(marker) == []                                # the child went with its program


def test_captured_output_is_bounded_to_its_tail(cache, tmp_path):
    root, _ = cache
    script = tmp_path / "chatty.py"
    script.write_text("import sys\nfor i in range(200000):\n    print(f'line {i}', file=sys.stderr)\n"
                      "print('the last word', file=sys.stderr)\nsys.exit(4)\n")
    r = check_process(root, "--estimator", f"cmd:{sys.executable} {script} {{dataset}} {{out}}", "--max-ate", "1")
    assert r.returncode == 2 and "exit code 4: the last word" in r.stderr
    assert "earlier output cut" in r.stderr and "line 0\n" not in r.stderr
    assert len(r.stderr) < 70_000                                 # 2.5 MB printed, 64 KiB kept


def test_templates_literal_braces_and_bad_quotes(cache, tmp_path):
    root, _ = cache
    script = tmp_path / "braces.py"
    script.write_text("import sys\nassert sys.argv[3] == '{literal}', sys.argv\n"
                      "open(sys.argv[2], 'w').write('1 0 0 0 0 0 0 1\\n')\n")
    r = check_process(root, "--estimator", f"cmd:{sys.executable} {script} {{dataset}} {{out}} {{{{literal}}}}",
                      "--max-ate", "1")
    assert r.returncode == 1, r.stderr                            # ran (one pose: coverage fails), braces literal
    r = check_process(root, "--estimator", f"cmd:{sys.executable} '{script} {{dataset}} {{out}}", "--max-ate", "1")
    assert r.returncode == 2 and "No closing quotation" in r.stderr and "Traceback" not in r.stderr
    r = check_process(root, "--estimator", f"cmd:{sys.executable} {script} {{data}} {{out}}", "--max-ate", "1")
    assert r.returncode == 2 and "unknown field {data}" in r.stderr
    r = check_process(root, "--estimator", f"cmd:{sys.executable} {script} {{dataset}} {{out}}", "--max-ate", "1",
                      "--timeout", "0")
    assert r.returncode == 2 and "--timeout: must be a number of seconds > 0, got 0.0" in r.stderr
    r = check_process(root, "--estimator", "cmd:no-such-vo {dataset} {out}", "--max-ate", "1")
    assert r.returncode == 2 and "program not found (no-such-vo)" in r.stderr


def test_program_environment_and_arguments_name_nothing_of_ours(cache, tmp_path):
    root, _ = cache
    script = tmp_path / "env.py"
    script.write_text("import json, os, sys\nprint('ENV ' + json.dumps([dict(os.environ), sys.argv, os.getcwd()]),"
                      " file=sys.stderr)\nsys.exit(1)\n")
    r = check_process(root, "--estimator", f"cmd:{sys.executable} {script} {{dataset}} {{out}}", "--max-ate", "1")
    env, argv, cwd = json.loads(next(ln for ln in r.stderr.splitlines() if ln.startswith("ENV "))[4:])
    assert set(env) <= {"PATH", "LANG", "LANGUAGE", "TZ", "TERM", "HOME", "PWD", "TMPDIR"} | {
        k for k in env if k.startswith("LC_")}, env
    assert not any(str(root) in v or "smoke" in v for v in list(env.values()) + argv + [cwd])
    assert env["HOME"] == cwd == str(Path(argv[2]).parent)        # its own empty output folder


class PeekEstimator(Estimator):
    """A plug-in that would use the truth if it were handed it."""

    name = "peek"

    def set_dataset(self, dataset) -> None:
        seen = [a for a in ("groundtruth", "groundtruth_cam0", "path", "root", "gcps", "depth", "segmentation",
                            "metadata") if hasattr(dataset, a)]
        if seen:
            raise RuntimeError(f"saw {', '.join(seen)}")
        self.n = len(dataset)
        assert dataset.imu is not None and len(dataset.frame_times_ns) == self.n

    def process(self, frame):
        return FrameResult(frame.t_ns, np.eye(4))


class PeekOracle(PeekEstimator):
    @classmethod
    def is_oracle(cls, options):
        return True

    def set_dataset(self, dataset) -> None:
        self.truth = dataset.groundtruth_cam0()


def test_in_process_plugins_get_sensors_only_and_oracles_are_refused(cache, tmp_path):
    from vo.dataset import open_dataset
    from vo.estimators.registry import is_oracle
    from vo.estimators.runner import run_estimator
    root, path = cache
    ds = open_dataset(path)
    assert len(run_estimator("test_check_isolation:PeekEstimator", ds, progress=False, max_frames=2).frames) == 2
    assert len(run_estimator("test_check_isolation:PeekOracle", ds, progress=False, max_frames=2).frames) == 2
    assert is_oracle("vins-oracle") and is_oracle("vins", {"init": "truth"}) and not is_oracle("vins")
    assert not any(is_oracle(n) for n in ("rop", "klt-pnp", "orb-pnp", "vins-ac-me"))
    for args in (["--estimator", "vins-oracle"], ["--estimator", "vins", "--opt", "init=truth"],
                 ["--estimator", "test_check_isolation:PeekOracle"]):
        r = check_process(root, *args, "--max-ate", "1", path_env=None)
        assert r.returncode == 2 and "reads ground truth" in r.stderr, (args, r.stderr)


def test_own_files_are_shown_and_the_cache_inside_them_is_covered(tmp_path):
    """What namespace isolation binds besides the system: a venv's root and its base Python; the folder of a
    path in the template; the cache covered when inside it; a program inside the cache refused."""
    from vo.errors import EstimatorError
    from vo.estimators.isolation import hidden_within, own_paths
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    base = tmp_path / "python3.11"
    (base / "bin").mkdir(parents=True)
    (venv / "pyvenv.cfg").write_text(f"home = {base / 'bin'}\n")
    exe = venv / "bin" / "python"
    exe.write_text("")
    exe.chmod(0o755)
    proj = tmp_path / "proj"
    (proj / ".cache" / "vo-testbed").mkdir(parents=True)
    (proj / "my_vo.py").write_text("")
    own = own_paths([str(exe), "my_vo.py", "--fast", "{dataset}"], proj)
    assert set(own) == {venv, base, proj}
    assert hidden_within(own, (proj / ".cache" / "vo-testbed",)) == ((proj / ".cache" / "vo-testbed").resolve(),)
    with pytest.raises(EstimatorError, match="lie inside"):
        hidden_within(own, (proj,))
    link = tmp_path / "link"                                     # the project reached through a symbolic link
    link.symlink_to(proj)
    own = own_paths([str(exe), str(link / "my_vo.py")], tmp_path)
    assert {link, proj.resolve()} <= set(own)
    cache = proj / ".cache" / "vo-testbed"
    assert {link / ".cache" / "vo-testbed", cache.resolve()} <= set(hidden_within(own, (cache,)))
    assert hidden_within((), ("/etc/ssl",)) == (Path("/etc/ssl"),)   # a cache under a system folder is covered
