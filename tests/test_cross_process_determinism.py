"""The stereo estimators give byte-identical trajectories in separate processes, whatever the process's
memory layout and thread settings.

Each run is a fresh interpreter (``python -c``) running the product's frame loop (``run_estimator``, as
``vo-testbed run`` does) and printing the SHA-256 of every pose's float64 bytes. The second process differs in
what can change the last bits of a fit without changing its inputs: the heap's state (a spread of allocations
of odd sizes before the run, so the estimator's arrays start at other addresses and numpy's SIMD reductions
peel other elements), BLAS/OpenMP thread counts, OpenCV's thread count and the hash seed. The real turn's
``klt-pnp`` once differed across processes this way (its disparity-offset fit followed the alignment of its
arrays: docs/estimators.md, "`klt-pnp`: the disparity offset estimated online").
"""
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("VO_TESTBED_REAL_DATA", REPO.parent / "shared" / "data" / "real"))

RUN = """
import hashlib, sys
import numpy as np
salt = int(sys.argv[4])
junk = [np.empty(1 + (37 * k) % 301) for k in range(salt)]        # shift the heap: other array addresses
junk += [bytearray(1 + (53 * k) % 997) for k in range(salt)]
import cv2
cv2.setNumThreads(int(sys.argv[5]))
from vo.dataset import open_dataset
from vo.dataset.fisheye_view import for_estimators
from vo.estimators.runner import run_estimator
ds = for_estimators(open_dataset(sys.argv[1]))
run = run_estimator(sys.argv[2], ds, progress=False, max_frames=int(sys.argv[3]))
T = np.ascontiguousarray(run.trajectory.T, np.float64)
print(len(T), hashlib.sha256(T.tobytes()).hexdigest(), repr(T[-1, :3, 3].tolist()))
"""

# (heap salt, OpenCV threads, environment): the first is the plain process, the second is perturbed
PLAIN = (0, 1, {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"})
PERTURBED = (257, 2, {"OMP_NUM_THREADS": "2", "OPENBLAS_NUM_THREADS": "2", "PYTHONHASHSEED": "12345"})


def run_in_process(dataset, estimator: str, n_frames: int, variant) -> str:
    """One run of ``estimator`` on the first ``n_frames`` of ``dataset`` in a fresh interpreter -> its output line
    (frame count, SHA-256 of the poses, last position)."""
    salt, cv_threads, extra = variant
    env = dict(os.environ, PYTHONPATH=str(REPO), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), **extra)
    r = subprocess.run([sys.executable, "-c", RUN, str(dataset), estimator, str(n_frames), str(salt), str(cv_threads)],
                       env=env, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout.strip().splitlines()[-1]


def _assert_same_bytes(dataset, estimator: str, n_frames: int) -> None:
    a = run_in_process(dataset, estimator, n_frames, PLAIN)
    b = run_in_process(dataset, estimator, n_frames, PERTURBED)
    assert a.split()[0] == str(n_frames)
    assert a == b, f"{estimator}: the trajectories differ across processes:\n{a}\n{b}"


@pytest.mark.slow
@pytest.mark.parametrize("estimator", ["rop", "klt-pnp"])
def test_two_processes_give_the_same_trajectory_bytes(campus_short, estimator):
    """The first 30 frames of the 6 s campus sequence (a few keyframes, the offset fit and the ROP adjustment
    run): the same bytes in a plain and a perturbed process."""
    _assert_same_bytes(campus_short, estimator, 30)


# heap salts of the perturbed processes on the real turn: a layout flips an alignment-sensitive decision with
# some probability (about 1 in 4 layouts for the rank-deficient offset fit once there), so several are tried
REAL_SALTS = (2, 5, 100, 257)


@pytest.mark.slow
@pytest.mark.parametrize("estimator", ["rop", "klt-pnp"])
def test_two_processes_give_the_same_trajectory_bytes_on_the_real_turn(estimator):
    """The whole real KITTI turn (51 frames, every frame a keyframe, the disparity offset applied: where the
    processes once differed) in a plain process and in perturbed ones with :data:`REAL_SALTS` heap layouts."""
    seq = REAL / "kitti_turn"
    if not seq.is_dir():
        pytest.skip(f"{seq}: real KITTI excerpt not present")
    plain = run_in_process(seq, estimator, 51, PLAIN)
    assert plain.split()[0] == "51"
    for salt in REAL_SALTS:
        other = run_in_process(seq, estimator, 51, (salt, *PERTURBED[1:]))
        assert other == plain, f"{estimator}, heap salt {salt}: the trajectories differ across processes:\n{plain}\n{other}"


@pytest.mark.slow
def test_the_runs_see_their_inputs():
    """The hash follows the run: a different frame count gives a different one. (The real-turn test above fails
    against the code before ``klt-pnp``'s offset fit was rounded, and against the code before it left out frames
    that see fewer than 3 landmarks: heap salts 2 and 100, or 5, 7, 10 and 22 of 0-24, gave another trajectory.)"""
    seq = REAL / "kitti_turn"
    if not seq.is_dir():
        pytest.skip(f"{seq}: real KITTI excerpt not present")
    a = run_in_process(seq, "klt-pnp", 3, PLAIN)
    b = run_in_process(seq, "klt-pnp", 4, PLAIN)
    assert a.split()[1] != b.split()[1]
