"""The frame pipeline: frames committed in order with bounded memory; pipelined generation writes the bytes
of the serial loop (with and without image effects); a pipelined run interrupted by SIGINT in a real
process resumes to the same bytes; the camera's noise draw has the exact rounded-Gaussian distribution."""
import hashlib
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from foreground import foreground_sigint
from sim.generate_config import GenerateConfig
from sim.frame_pipeline import FramePipeline
from rigs.image_noise import _offset_table, add_quantized_noise, offset_probabilities

ROOT = Path(__file__).resolve().parents[1]
SHORT = GenerateConfig(scene="indoor", rig="stereo27", duration_s=0.5, seed=3)


def digest(path):
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*")) if p.is_file()}


def test_pipeline_commits_in_order_with_bounded_frames_in_flight():
    lock, alive, peak, committed = threading.Lock(), [0], [0], []
    rng = np.random.default_rng(0)
    delays = rng.uniform(0, 0.004, 60)             # later frames often finish first

    def work(k):
        with lock:
            alive[0] += 1
            peak[0] = max(peak[0], alive[0])
        time.sleep(delays[k])
        return k

    def commit(k):
        with lock:
            alive[0] -= 1
        committed.append(k)

    with FramePipeline(threads=4, depth=6) as p:
        for k in range(60):
            p.submit(lambda k=k: work(k), commit)
            assert len(p._pending) <= 6
    assert committed == list(range(60)) and peak[0] <= 6


def test_pipeline_error_stops_the_commits():
    committed = []

    def work(k):
        if k == 5:
            raise ValueError("frame 5")
        return k

    with pytest.raises(ValueError, match="frame 5"):
        with FramePipeline(threads=2, depth=3) as p:
            for k in range(20):
                p.submit(lambda k=k: work(k), committed.append)
    assert committed == list(range(5))


@pytest.mark.slow
@pytest.mark.parametrize("items", [
    ["format=both", "depth=true", "depth_format=png16", "segmentation=true"],
    ["camera.auto_exposure=true", "camera.vignetting=0.5", "camera.exposure_ms=4", "camera.blur_subframes=2"],
], ids=["formats-depth-seg", "effects-auto-exposure"])
def test_pipelined_generation_is_byte_identical_to_the_serial_loop(tmp_path, items):
    from sim.generate import generate
    cfg = SHORT.with_overrides(items)
    generate(cfg, tmp_path / "serial", progress=False, threads=0)
    generate(cfg, tmp_path / "pipelined", progress=False, threads=3)
    a, b = digest(tmp_path / "serial"), digest(tmp_path / "pipelined")
    assert len(a) > 20 and a == b


@pytest.mark.slow
def test_multi_worker_generation_is_byte_identical_to_the_serial_loop(tmp_path):
    """Two render processes (11 frames in chunks of 3, which may finish out of order) against the serial
    loop, with per-frame image effects; the rendering record names the same renderer on one machine."""
    from sim.generate import generate
    cfg = SHORT.with_overrides(["format=both", "segmentation=true", "camera.exposure_ms=4",
                                "camera.blur_subframes=2", "camera.vignetting=0.3"])
    generate(cfg, tmp_path / "serial", progress=False, threads=0)
    from sim.render_workers import chunk_ranges
    assert chunk_ranges(0, 11, 3) == [(0, 3), (3, 6), (6, 9), (9, 11)]
    generate(cfg, tmp_path / "workers", progress=False, workers=2)
    a, b = digest(tmp_path / "serial"), digest(tmp_path / "workers")
    assert len(a) > 40 and a == b
    assert "rendering:" in (tmp_path / "workers" / "euroc" / "metadata.yaml").read_text()


def test_auto_exposure_is_not_split_over_workers(tmp_path):
    from sim.errors import SimError
    from sim.generate import generate
    with pytest.raises(SimError, match="camera.auto_exposure makes each frame's gain depend"):
        generate(SHORT.with_overrides(["camera.auto_exposure=true"]), tmp_path / "ae", progress=False, workers=2)
    assert not (tmp_path / "ae").exists()


CHILD = """
import sys
from sim.generate_config import GenerateConfig
from sim.generate import generate
if __name__ == "__main__":
    generate(GenerateConfig(scene="indoor", rig="stereo27", duration_s=3.0, seed=3), sys.argv[1], progress=False,
             threads=2, workers=int(sys.argv[2]))
"""


@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2], ids=["pipelined", "two-workers"])
def test_run_interrupted_by_sigint_resumes_byte_identically(tmp_path, workers):
    from sim.generate import generate
    cfg = GenerateConfig(scene="indoor", rig="stereo27", duration_s=3.0, seed=3)
    broken = tmp_path / "broken"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(broken), str(workers)], env=env, cwd=ROOT,
                             preexec_fn=foreground_sigint)
    rows = broken / "mav0" / "cam0" / "data.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and child.poll() is None:
        if rows.exists() and len(rows.read_text().splitlines()) > 3:     # header + 3 frames committed
            break
        time.sleep(0.05)
    child.send_signal(signal.SIGINT)
    assert child.wait(timeout=120) != 0
    n_rows = len(rows.read_text().splitlines()) - 1
    assert (broken / "INCOMPLETE").exists() and not (broken / "metadata.yaml").exists() and 3 <= n_rows < 61
    assert not list(broken.rglob(".*.tmp*"))                           # no temporary file left behind
    generate(cfg, broken, progress=False, threads=2, workers=workers)  # resumes after the frames on disk
    generate(cfg, tmp_path / "straight", progress=False, threads=0)
    assert digest(broken) == digest(tmp_path / "straight")


def test_quantized_noise_table_holds_the_exact_probabilities():
    """P(d) of rint(sigma n) = d from erf (exact to float64), and the table + residual draw reproduce it:
    floor(65536 P) whole entries plus the residual mass, summing to P(d) within 1e-15."""
    for sigma in (0.4, 1.0, 3.0, 40.0):
        d, p = offset_probabilities(sigma)
        assert abs(p.sum() - 1.0) < 1e-12 and np.allclose(p, p[::-1], rtol=0, atol=1e-17)
        phi = lambda x: 0.5 * math.erfc(-x / math.sqrt(2))  # noqa: E731
        assert abs(p[255 + 1] - (phi(1.5 / sigma) - phi(0.5 / sigma))) < 1e-15
        table, values, cdf = _offset_table(sigma)
        whole = np.array([(table == v).sum() for v in values]) / 65536.0
        residual = np.diff(np.concatenate([[0.0], cdf])) / 65536.0
        assert np.abs(whole + residual - p).max() < 1e-15


@pytest.mark.parametrize("sigma", [0.7, 1.0, 3.0])
def test_quantized_noise_matches_the_rounded_gaussian(sigma):
    """2.9e6 draws on a mid-grey image: Pearson chi-square of the offsets against P(d) over cells with
    >= 20 expected counts, below the 99.9 % quantile (false alarm 1e-3 per sigma, fixed seed)."""
    from scipy.stats import chi2
    img = np.full((960, 1504), 128, np.uint8)
    off = np.concatenate([add_quantized_noise(img, sigma, np.random.default_rng(s)).ravel().astype(int) - 128
                          for s in (11, 12)])
    d, p = offset_probabilities(sigma)
    expected = p * off.size
    counts = np.bincount(off + 255, minlength=511)
    cells = expected >= 20
    stat = ((counts[cells] - expected[cells]) ** 2 / expected[cells]).sum()
    assert stat < chi2.ppf(0.999, cells.sum() - 1)
    assert counts[~cells].sum() < 10 * max(expected[~cells].sum(), 1)   # tails not inflated
    # deterministic per generator, clipped at the ends, sigma 0 draws nothing
    a = add_quantized_noise(img[:40, :60], sigma, np.random.default_rng(5))
    assert np.array_equal(a, add_quantized_noise(img[:40, :60], sigma, np.random.default_rng(5)))
    ends = np.array([[0, 255] * 50] * 20, np.uint8)
    assert add_quantized_noise(ends, 50.0, np.random.default_rng(1)).dtype == np.uint8
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    assert np.array_equal(add_quantized_noise(img, 0.0, rng), img) and rng.bit_generator.state == state


@pytest.mark.parametrize("args, needle", [
    (("--workers", "2", "--set", "camera.auto_exposure=true"), "camera.auto_exposure makes each frame's gain"),
    (("--set", "render.png_compression=12"), "render.png_compression: must be in [0, 9], got 12"),
    (("--set", "render.png_strategy=zip"), "render.png_strategy: unknown 'zip'; valid: default, filtered, huffman"),
])
def test_generate_speed_options_bad_input_is_one_line_exit_2(args, needle, tmp_path, capsys):
    from test_bad_input_cli import assert_one_line_exit_2, vo_testbed
    code, _, err = vo_testbed(capsys, "generate", "--scenario", "smoke", *args, "--out", tmp_path / "ds")
    assert_one_line_exit_2(code, err, needle)
    assert not (tmp_path / "ds").exists()                       # refused before anything was written


@pytest.mark.slow
def test_frame_ranges_on_a_dask_cluster_give_the_serial_bytes(tmp_path):
    """--scheduler: the chunks go to a Dask cluster (one local worker process here) and the dataset is the
    serial loop's, byte for byte."""
    distributed = pytest.importorskip("dask.distributed")     # the sweep extra
    from sim.generate import generate
    generate(SHORT, tmp_path / "serial", progress=False, threads=0)
    os.environ.setdefault("MUJOCO_GL", "egl")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        generate(SHORT, tmp_path / "dask", progress=False, scheduler=cluster.scheduler_address)
    assert digest(tmp_path / "serial") == digest(tmp_path / "dask")


def _bytewise_lookup_noise(img, sigma, rng):
    """The draw of dataset version 0.4.0 written plainly: a uniform byte per pixel (the raw PCG64 words'
    little-endian bytes, else ``integers``) picks a bucket of the sorted 65536-entry table; a bucket of one
    offset |d| <= 127 gives it, any other draws a low byte (in pixel order) for the full 16-bit index, and a
    residual entry an inverse-CDF draw of the residual masses."""
    table, values, cdf = _offset_table(sigma)

    def uniform_bytes(n):
        if type(rng.bit_generator) is not np.random.PCG64:
            return rng.integers(0, 256, size=n, dtype=np.uint8)
        words = rng.bit_generator.random_raw(-(-n // 8))
        return np.frombuffer(b"".join(int(w).to_bytes(8, "little") for w in words), np.uint8)[:n]

    buckets = table.reshape(256, 256).astype(int)
    resolved = (buckets == buckets[:, :1]).all(axis=1) & (np.abs(buckets[:, 0]) <= 127)
    high = uniform_bytes(img.size).astype(int)
    offsets = buckets[high, 0]
    mixed = np.flatnonzero(~resolved[high])
    offsets[mixed] = table[high[mixed] * 256 + uniform_bytes(mixed.size)]
    escaped = mixed[offsets[mixed] == np.iinfo(np.int16).min]
    if escaped.size:
        u = rng.random(escaped.size) * cdf[-1]
        offsets[escaped] = values[np.minimum(np.searchsorted(cdf, u, side="right"), len(values) - 1)]
    return np.clip(img.astype(int) + offsets.reshape(img.shape), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("sigma", [0.3, 1.0, 3.0, 40.0, 200.0])
def test_quantized_noise_bytes_are_the_bytewise_table_lookup(sigma):
    """The vectorised draw (cv2.LUT on the bucket byte, low bytes and the full table for mixed buckets, a
    saturating add) writes the bytes of the plain bytewise look-up and leaves the generator where it leaves
    it: odd sizes (a partial last word), colour, and a non-PCG64 bit generator (32-bit raw words)."""
    g = np.random.default_rng(0)
    for shape in [(480, 752), (37, 53), (20, 30, 3), (1, 1)]:
        img = g.integers(0, 256, shape, dtype=np.uint8)
        for make in (lambda: np.random.default_rng(7), lambda: np.random.Generator(np.random.MT19937(7))):
            a, b = make(), make()
            assert np.array_equal(add_quantized_noise(img, sigma, a), _bytewise_lookup_noise(img, sigma, b))
            assert a.integers(0, 2**32, 3, dtype=np.uint32).tolist() == b.integers(0, 2**32, 3, dtype=np.uint32).tolist()
            assert np.array_equal(add_quantized_noise(img, sigma, a), _bytewise_lookup_noise(img, sigma, b))
            assert a.random() == b.random()


@pytest.mark.parametrize("sigma", [1.0, 4.0])
def test_quantized_noise_per_intensity_is_the_clipped_rounded_gaussian(sigma):
    """Every grey level 0..255, 4096 pixels each (fixed seed): the output's per-level histogram against the
    exact law of clip(v + rint(sigma n), 0, 255) (P(d) from erf, clipping at both ends): Pearson chi-square
    over all levels' cells with >= 20 expected counts below its 99.9 % quantile, and every level's mean and
    variance within 5 standard errors of the exact moments (false alarm about 3e-4 over the 512 checks)."""
    from scipy.stats import chi2
    n_per = 4096
    img = np.repeat(np.arange(256, dtype=np.uint8), n_per).reshape(512, 2048)
    out = add_quantized_noise(img, sigma, np.random.default_rng(2024)).reshape(256, n_per).astype(int)
    d, p = offset_probabilities(sigma)
    stat, dof = 0.0, 0
    levels = np.arange(256)
    for v in range(256):
        exact = np.bincount(np.clip(v + d, 0, 255), weights=p, minlength=256)      # P(out = o | v)
        counts = np.bincount(out[v], minlength=256)
        cells = exact * n_per >= 20
        stat += ((counts[cells] - exact[cells] * n_per) ** 2 / (exact[cells] * n_per)).sum()
        dof += cells.sum() - 1
        assert counts[~cells].sum() < 10 * max(exact[~cells].sum() * n_per, 1)   # tails not inflated
        mean = (levels * exact).sum()
        var = ((levels - mean) ** 2 * exact).sum()
        mu4 = ((levels - mean) ** 4 * exact).sum()
        assert abs(out[v].mean() - mean) < 5 * np.sqrt(var / n_per), (v, out[v].mean(), mean)
        assert abs(out[v].var() - var) < 5 * np.sqrt((mu4 - var ** 2) / n_per) + 1e-12, (v, out[v].var(), var)
    assert stat < chi2.ppf(0.999, dof)


def test_quantized_noise_is_the_same_from_concurrent_threads():
    """Worker threads noise frames concurrently with per-thread work arrays: 4 threads x 6 frames of two
    sizes give the serial bytes."""
    from concurrent.futures import ThreadPoolExecutor
    imgs = [np.random.default_rng(k).integers(0, 256, (240, 376) if k % 2 else (480, 752), dtype=np.uint8)
            for k in range(24)]
    serial = [add_quantized_noise(im, 1.5, np.random.default_rng(k)) for k, im in enumerate(imgs)]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda k: add_quantized_noise(imgs[k], 1.5, np.random.default_rng(k)), range(24)))
    assert all(np.array_equal(a, b) for a, b in zip(serial, threaded))
