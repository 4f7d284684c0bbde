"""Data cannot be corrupted: locked output folders and cache entries, atomic completion, verified cache
entries, ``--overwrite`` limited to our own datasets (docs/bad_input.md). Process things are tested with
real processes: two writers at once, and a generation interrupted by SIGINT during its bag step."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from foreground import foreground_sigint
from sim.app.cli import main
from sim.writers.common import MARKER, OWNER
from sim.writers.locking import LOCK_NAME, FolderBusy, FolderLock, holder_pid
from sim.writers.manifest import verify_manifest

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-c", "from sim.app.cli import main; main()"]
SMOKE_1S = ["--scenario", "smoke", "--duration", "1", "--no-progress"]       # 21 stereo frames, a few seconds


def env(**extra) -> dict:
    e = dict(os.environ, MUJOCO_GL="egl", PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    e.update({k: str(v) for k, v in extra.items()})
    return e


def spawn(args, **extra) -> subprocess.Popen:
    return subprocess.Popen(args, cwd=REPO, env=env(**extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=foreground_sigint)


def wait_for(predicate, proc: subprocess.Popen, what: str, timeout_s: float = 120.0, step_s: float = 0.01) -> None:
    """Poll ``predicate`` until true; fail when ``proc`` ends first or after ``timeout_s``."""
    t_end = time.monotonic() + timeout_s
    while not predicate():
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"process ended (rc {proc.returncode}) before {what}: {err[-2000:]}")
        if time.monotonic() > t_end:
            proc.kill()
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(step_s)


def vo_testbed(capsys, *args):
    code = 0
    try:
        main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert "Traceback" not in err and len([ln for ln in lines if ln.startswith(("error:", "Error:"))]) == 1, err
    return next(ln for ln in lines if ln.startswith(("error:", "Error:")))


def data_rows(csv: Path) -> list:
    return [ln for ln in csv.read_text().splitlines() if ln and not ln.startswith("#")]


# ---------------------------------------------------------------------------------------------- the lock
def test_lock_names_its_holder_and_is_dropped_when_the_holder_dies(tmp_path):
    """A second FolderLock in another process fails at once naming our pid; a killed holder frees it."""
    lock = FolderLock(tmp_path / "x.lock", "thing").acquire(wait=False)
    probe = ("import sys; from sim.writers.locking import FolderLock, FolderBusy\n"
             "try:\n    FolderLock(sys.argv[1], 'thing').acquire(wait=False)\n"
             "except FolderBusy as e:\n    print(e.pid, e)\n    sys.exit(2)\n")
    r = subprocess.run([sys.executable, "-c", probe, str(tmp_path / "x.lock")], env=env(), capture_output=True,
                       text=True, cwd=REPO)
    assert r.returncode == 2 and r.stdout.startswith(f"{os.getpid()} thing: process {os.getpid()} is writing it")
    lock.release()
    assert holder_pid(tmp_path / "x.lock") is None          # emptied on release

    holder = spawn([sys.executable, "-c", "import sys, time; from sim.writers.locking import FolderLock; "
                    "FolderLock(sys.argv[1], 'thing').acquire(wait=False); time.sleep(600)", str(tmp_path / "y.lock")])
    wait_for(lambda: holder_pid(tmp_path / "y.lock") == holder.pid, holder, "the holder's lock")
    with pytest.raises(FolderBusy, match=f"process {holder.pid} is writing it"):
        FolderLock(tmp_path / "y.lock", "thing").acquire(wait=False)
    holder.kill()
    holder.wait()
    FolderLock(tmp_path / "y.lock", "thing").acquire(wait=False).release()   # the OS dropped the dead holder's lock


@pytest.mark.slow
def test_second_generate_into_one_out_exits_2_naming_the_first(tmp_path):
    """Two real ``generate`` runs into one ``--out``: the second exits 2 at once naming the first's pid;
    the first finishes a clean dataset (no duplicate rows, no INCOMPLETE, manifest intact)."""
    out = tmp_path / "ds"
    first = spawn(CLI + ["generate", *SMOKE_1S, "--out", str(out)])
    wait_for(lambda: holder_pid(out / LOCK_NAME) == first.pid, first, "the first run's lock")
    second = subprocess.run(CLI + ["generate", *SMOKE_1S, "--out", str(out)], env=env(), cwd=REPO,
                            capture_output=True, text=True)
    assert second.returncode == 2
    line = one_error_line(second.stderr)
    assert f"output folder {out}: process {first.pid} is writing it" in line, line
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    rows = data_rows(out / "mav0" / "cam0" / "data.csv")
    assert len(rows) == 21 and len(set(rows)) == 21
    assert not (out / MARKER).exists() and verify_manifest(out) == []
    assert "status: complete" in (out / "metadata.yaml").read_text()


@pytest.mark.slow
def test_two_processes_share_one_cache_entry(tmp_path):
    """Two processes fill one empty cache with the same scenario: the second waits for the first (and says
    so, naming it), then reuses the entry it wrote; the entry is whole and verified."""
    from sim.scenarios import cache_key, get_scenario
    cache = tmp_path / "cache"
    cfg = get_scenario("smoke", overrides=("duration_s=1",))
    script = ("from sim.scenarios import cached_dataset, get_scenario; "
              "print(cached_dataset(get_scenario('smoke', overrides=('duration_s=1',)), progress=False))")
    lock = cache / f".{cache_key(cfg)}.lock"
    first = spawn([sys.executable, "-c", script], VO_TESTBED_CACHE=cache)
    wait_for(lambda: holder_pid(lock) == first.pid, first, "the first process's cache lock")
    second = spawn([sys.executable, "-c", script], VO_TESTBED_CACHE=cache)
    out1, err1 = first.communicate(timeout=300)
    out2, err2 = second.communicate(timeout=300)
    assert first.returncode == 0 and second.returncode == 0, err1 + err2
    entry = cache / cache_key(cfg)
    assert out1.strip() == out2.strip() == str(entry)
    assert f"waiting for process {first.pid}, which is writing the cache entry {entry}" in err2
    rows = data_rows(entry / "mav0" / "cam0" / "data.csv")
    assert len(rows) == 21 and len(set(rows)) == 21
    assert verify_manifest(entry) == [] and not (entry / MARKER).exists()


@pytest.mark.slow
def test_damaged_cache_entry_is_regenerated_with_a_warning(tmp_path, monkeypatch, capsys):
    """A cache entry whose IMU file was edited in place (same size) is found by its manifest, regenerated
    with a warning, and comes back byte for byte."""
    from sim.scenarios import cached_dataset, get_scenario
    monkeypatch.setenv("VO_TESTBED_CACHE", str(tmp_path))
    cfg = get_scenario("smoke", overrides=("duration_s=0.5", "images=false"))
    entry = cached_dataset(cfg, progress=False)
    imu = entry / "mav0" / "imu0" / "data.csv"
    original = imu.read_bytes()
    assert cached_dataset(cfg, progress=False) == entry and "damaged" not in capsys.readouterr().err
    lines = original.decode().split("\n")
    lines[5] = lines[5][:-1] + ("1" if lines[5][-1] != "1" else "2")         # one digit, same size
    imu.write_text("\n".join(lines))
    assert verify_manifest(entry) == ["mav0/imu0/data.csv was modified (SHA-256 differs)"]
    assert cached_dataset(cfg, progress=False) == entry
    err = capsys.readouterr().err
    assert f"warning: cache entry {entry} is damaged (mav0/imu0/data.csv was modified (SHA-256 differs)); " \
           f"regenerating it" in err
    assert imu.read_bytes() == original and verify_manifest(entry) == []
    (entry / "topdown.png").unlink()                                          # a missing file
    assert verify_manifest(entry) == ["topdown.png is missing"]
    assert cached_dataset(cfg, progress=False) == entry and verify_manifest(entry) == []
    assert "damaged (topdown.png is missing)" in capsys.readouterr().err
    (entry / OWNER).unlink()                                                  # a folder generate did not make
    (entry / MARKER).write_text("config=0 frames=3\n")
    assert cached_dataset(cfg, progress=False) == entry and verify_manifest(entry) == []
    assert f"warning: cache entry {entry} was not written by vo-testbed generate; regenerating it" \
        in capsys.readouterr().err
    assert imu.read_bytes() == original


def test_cache_key_follows_the_renderer_versions():
    from sim.scenarios import cache_key, get_scenario, renderer_versions
    cfg = get_scenario("smoke")
    v = renderer_versions()
    assert set(v) == {"vo-testbed", "dataset", "mujoco", "opencv"}
    import cv2
    import mujoco
    assert v["mujoco"] == mujoco.__version__ and v["opencv"] == cv2.__version__
    assert cache_key(cfg) == cache_key(cfg, v)
    for name in v:
        assert cache_key(cfg, dict(v, **{name: v[name] + ".1"})) != cache_key(cfg)


# ---------------------------------------------------------------------------------------------- completion
@pytest.mark.slow
def test_sigint_during_the_bag_step_leaves_a_folder_that_resumes(tmp_path):
    """Ctrl-C while ``generate --format rosbag1`` writes its bag: no ``status: complete``, the folder stays
    INCOMPLETE; the rerun resumes (frames kept) and completes with the bag."""
    out = tmp_path / "ds"
    args = CLI + ["generate", "--scenario", "smoke", "--format", "rosbag1", "--no-progress", "--out", str(out)]
    run = spawn(args)
    wait_for(lambda: (out / "dataset.bag").exists(), run, "the bag step", step_s=0.005)
    frames = data_rows(out / "mav0" / "cam0" / "data.csv")
    run.send_signal(signal.SIGINT)
    _, err = run.communicate(timeout=120)
    assert run.returncode == 130, err
    assert "Traceback" not in err
    assert (out / MARKER).exists() and not (out / "metadata.yaml").exists() and not (out / "dataset.bag").exists()
    assert len(frames) == 61
    pngs = {p: p.stat().st_mtime_ns for p in (out / "mav0" / "cam0" / "data").iterdir()}

    again = subprocess.run(args, env=env(), cwd=REPO, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "wrote 61 stereo frames" in again.stdout
    assert {p: p.stat().st_mtime_ns for p in (out / "mav0" / "cam0" / "data").iterdir()} == pngs  # resumed
    assert not (out / MARKER).exists() and (out / "dataset.bag").stat().st_size > 0
    assert "status: complete" in (out / "metadata.yaml").read_text() and verify_manifest(out) == []


# ---------------------------------------------------------------------------------------------- --overwrite
@pytest.mark.slow
def test_overwrite_deletes_only_a_folder_of_ours(tmp_path, capsys):
    """A ROS 2 bag folder (it holds a metadata.yaml) is not ours: --overwrite refuses it and leaves it as
    it was; our own dataset carries the marker and is replaced."""
    bag = tmp_path / "rosbag2"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 8}\n")
    (bag / "rosbag2_0.mcap").write_bytes(b"\x89MCAP0\r\n")
    code, _, err = vo_testbed(capsys, "generate", *SMOKE_1S, "--no-images", "--overwrite", "--out", bag)
    assert code == 2
    assert one_error_line(err) == (f"error: {bag}: folder is not empty and was not written by vo-testbed "
                                   f"(no {OWNER} marker); refusing to delete it")
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "rosbag2_0.mcap"]

    ours = tmp_path / "ours"
    assert vo_testbed(capsys, "generate", *SMOKE_1S, "--no-images", "--out", ours)[0] == 0
    (ours / "stale.txt").write_text("from an older run")
    code, _, err = vo_testbed(capsys, "generate", *SMOKE_1S, "--no-images", "--overwrite", "--out", ours)
    assert code == 0, err
    assert (ours / OWNER).is_file() and not (ours / "stale.txt").exists() and verify_manifest(ours) == []


def test_generate_into_a_path_below_a_file_exits_2(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    code, _, err = vo_testbed(capsys, "generate", *SMOKE_1S, "--no-images", "--out", tmp_path / "afile" / "sub")
    assert code == 2
    assert one_error_line(err) == f"error: {tmp_path / 'afile' / 'sub'}: cannot create the output folder: Not a directory"
