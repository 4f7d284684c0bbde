"""``vo-testbed bench generate``: dataset generation speed against the renderer's, and its memory.

One run of :func:`bench_generate` on a scenario's first ``frames`` frames, side by side:

- *render only*: the same frames rendered in this process by the camera sensor
  (:class:`sim.sensors.camera.StereoCamera`, the scenario's rig, scene, poses and actors) and dropped;
- *end to end*: :func:`sim.generate.generate` into a temporary folder (render, noise and effects, PNG
  encoding, writing), timed over its frame loop (scene building, IMU and truth files left out, as for
  render only the GL context's creation); with ``workers > 1`` the frames are rendered by that many
  processes (:mod:`sim.render_workers`), their start-up included (the world built once in this process,
  ``startup_s['world_build']``, then each process loads it and makes its GL context, ``start-up`` in the
  stage figures and ``startup_s['worker_mean']``, elapsed and CPU seconds, its parts in ``startup_s['parts']``);
  the writing process renders chunks too while the workers start (``startup_s['frames_here']``,
  ``first_worker_chunk``); *after start-up* is the end-to-end rate from the arrival of the first rendered
  chunk (of any renderer) to the end, the rate a long route approaches. The workers' stage times come back
  with each chunk and are summed over the processes; the render-only run stays one process.
  ``world``: where the end-to-end run's world came from (``hit``: the machine's world cache,
  :mod:`sim.world_cache`; ``miss``: built, then stored; ``off``: built, ``VO_TESTBED_WORLD_CACHE=0``) and its
  elapsed and CPU seconds (``world_build`` above with workers).

``repeat`` alternates the two and keeps each one's best run (the machine may be shared). Per-stage
figures are thread-milliseconds per pair (:class:`sim.stage_timer.StageTimer`; the worker threads run
concurrently, so they may add up to more than the elapsed time); ``render`` excludes ``read-back``
(``mjr_readPixels``, which also waits for the renderer to finish). Peak memory is the process's peak
resident set (``ru_maxrss``), and with workers the largest worker process's;
``renderer`` names the GL renderer and EGL device of the render-only run, ``end_to_end_renderers`` those of
the end-to-end run (``metadata.yaml``'s ``rendering``). :func:`png_levels` times PNG encoding of the scenario's noisy frames at
every zlib level, strategy and row filter (``render.png_compression``, ``png_strategy``, ``png_filter``).
"""
from __future__ import annotations

import os
import resource
import shutil
import tempfile
import time
from dataclasses import asdict, dataclass, field

import cv2
import numpy as np
import yaml

from rigs.image_noise import add_image_noise, add_quantized_noise
from sim.frame_pipeline import default_threads
from sim.generate import generate, resolve
from sim.generate_config import PNG_FILTERS, PNG_STRATEGIES, PNG_STRATEGY
from sim.render_workers import device_label
from sim.rng import indexed_stream
from sim.scenarios import get_scenario
from sim.sensors.camera import StereoCamera, add_noise
from sim.stage_timer import StageTimer
from sim.writers.common import METADATA, PngOptions, encode_png

STAGES = ("render", "read-back", "noise/effects", "rectify", "encode", "write", "start-up")


@dataclass(frozen=True)
class GenerateBench:
    scenario: str
    frames: int
    threads: int
    workers: int
    png: str                                          # PNG options: level, strategy, filter
    render_pairs_per_s: float
    end_to_end_pairs_per_s: float
    stage_ms: dict = field(default_factory=dict)     # thread-ms per pair and stage (STAGES)
    peak_rss_mb: float = 0.0
    render_cpu_ms: float = 0.0                        # process CPU ms per pair (all threads), render only
    end_to_end_cpu_ms: float = 0.0                    # and end to end: robust to other load
    cpus: int = 0
    load_avg: tuple = ()                              # 1-minute load average before and after
    after_start_pairs_per_s: float = 0.0             # with workers: end to end once the first chunk is in
    renderer: str = ""                                # render only: GL renderer and EGL device (device_label)
    end_to_end_renderers: tuple = ()                  # end to end: metadata.yaml's ``rendering`` (per process)
    peak_rss_children_mb: float = 0.0                 # the largest render worker process's peak (workers > 1)
    startup_s: dict = field(default_factory=dict)     # workers > 1: world build here, mean per worker, first chunk
    world: dict = field(default_factory=dict)         # the end-to-end run's world: cache hit / miss / off, s, CPU s

    @property
    def ratio(self) -> float:
        return self.end_to_end_pairs_per_s / self.render_pairs_per_s

    def to_dict(self) -> dict:
        return dict(asdict(self), ratio=self.ratio)


def frames_config(scenario: str, frames: int | None, overrides=()):
    """The scenario's config cut to its first ``frames`` frames (None or 0: the whole route)."""
    cfg = get_scenario(scenario, overrides)
    if frames:
        rate = cfg.rig.camera_rate_hz
        cfg = cfg.with_value("duration_s", max(frames - 1, 1) / rate)
    return cfg


def render_only(setup, timer=None) -> tuple:
    """``(pairs, seconds, CPU seconds, device label)``: every frame of ``setup`` rendered by the camera
    sensor, nothing else; the label names the GL renderer and EGL device (:func:`sim.render_workers.device_label`)."""
    c = setup.config
    T_w_b = setup.trajectory.states(setup.frame_t_ns).T_w_b
    with StereoCamera(setup.scene, setup.rig, vehicle=c.vehicle, depth=c.depth, segmentation=c.segmentation,
                      supersample=setup.supersample, rgb=c.rgb, timer=timer) as camera:
        t0, c0 = time.perf_counter(), time.process_time()
        for k, t_ns in enumerate(setup.frame_t_ns):
            camera.measure(T_w_b[k], setup.scene.actor_states(int(t_ns)))
        return (len(setup.frame_t_ns), time.perf_counter() - t0, time.process_time() - c0,
                device_label(camera.gl_renderer))


def end_to_end(config, threads, workdir, workers: int = 1, scheduler=None) -> tuple:
    """``(pairs, seconds of the frame loop, its CPU seconds, StageTimer, renderers)`` of one
    :func:`sim.generate.generate` run; ``renderers``: its ``metadata.yaml``'s ``rendering`` list."""
    timer = StageTimer()
    out = tempfile.mkdtemp(prefix="bench-generate-", dir=workdir)
    try:
        res = generate(config, os.path.join(out, "ds"), progress=False, threads=threads, timer=timer,
                       workers=workers, scheduler=scheduler)
        with open(os.path.join(res.out_dir, METADATA)) as f:
            renderers = tuple((yaml.safe_load(f) or {}).get("rendering") or ())
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return res.n_frames, timer.seconds("frame loop"), timer.seconds("frame loop CPU"), timer, renderers


def bench_generate(scenario: str = "campus-short", frames: int | None = 100, threads: int | None = None,
                   repeat: int = 1, overrides=(), workdir=None, progress=None, workers: int = 1,
                   scheduler=None) -> GenerateBench:
    """Render-only and end-to-end pairs per second of ``scenario``'s first ``frames`` frames (module
    docstring); ``threads``: the pipeline's workers (None: one per CPU), ``overrides``: ``--set`` items."""
    config = frames_config(scenario, frames, overrides)
    threads = default_threads() if threads is None else int(threads)
    load0 = os.getloadavg()[0]
    setup = resolve(config)
    best_render, best_e2e, best_timer, n = (np.inf, np.inf), (np.inf, np.inf), None, 0
    after_start = 0.0
    for r in range(max(1, repeat)):
        n, dt, dc, device = render_only(setup)
        best_render = min(best_render, (dt, dc))
        n, dt, dc, timer, renderers = end_to_end(config, threads, workdir, workers, scheduler)
        if dt < best_e2e[0]:
            best_e2e, best_timer = (dt, dc), timer
        first_s, first_n = timer.seconds("first chunk"), timer.seconds("first chunk frames")
        if first_s and n > first_n and dt > first_s:
            after_start = max(after_start, (n - first_n) / (dt - first_s))
        if progress:
            progress(f"run {r + 1}/{repeat}: render only {n / best_render[0]:.1f}, "
                     f"end to end {n / best_e2e[0]:.1f} pairs/s")
    tot = best_timer.totals()
    stage_ms = {s: 1e3 * tot.get(s, 0.0) / n for s in STAGES}
    stage_ms["render"] -= stage_ms["read-back"]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    peak_children = max(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0,   # spawned workers
                        tot.get("worker peak MB", 0.0))       # forked by the forkserver: as they report it
    startup = {}
    if workers > 1 and not scheduler:
        startup = {"world_build": tot.get("world build", 0.0), "worker_mean": tot.get("start-up", 0.0) / workers,
                   "first_chunk": tot.get("first chunk", 0.0), "world_build_cpu": tot.get("world build CPU", 0.0),
                   "worker_mean_cpu": tot.get("start-up CPU", 0.0) / workers,
                   "first_worker_chunk": tot.get("first worker chunk", 0.0),
                   "frames_here": int(tot.get("frames here", 0.0)), "here_startup": tot.get("start-up here", 0.0),
                   "parts": {name: sec / (1 if name.startswith("start-up here") else workers)
                             for name, sec in tot.items() if name.startswith("start-up") and ": " in name}}
    world = {"cache": next((k.split()[-1] for k in tot if k.startswith("world cache ")), "off"),
             "seconds": tot.get("world build", 0.0), "cpu_s": tot.get("world build CPU", 0.0)}
    r = config.render
    png = f"level {r.png_compression}, {r.png_strategy}, {r.png_filter} filter"
    return GenerateBench(scenario, n, threads, workers, png, n / best_render[0],
                         n / best_e2e[0], stage_ms, peak, 1e3 * best_render[1] / n, 1e3 * best_e2e[1] / n,
                         os.cpu_count() or 0,
                         (round(load0, 2), round(os.getloadavg()[0], 2)), after_start, device, renderers,
                         peak_children, startup, world)


def png_levels(scenario: str = "campus-short", frames: int = 10, overrides=()) -> list:
    """``[{strategy, level, filter, kb_per_image, encode_ms_per_image}]`` for every zlib strategy
    (``render.png_strategy``) and level 0-9 (``render.png_compression``) with all row filters, then every
    row filter (``render.png_filter``) at level 1 with the default strategy, on ``frames`` frames of
    ``scenario`` spread over its route, noisy unless ``ideal``; encoding time is CPU time (one thread)."""
    setup = resolve(frames_config(scenario, None, overrides))
    c = setup.config
    picks = np.linspace(0, len(setup.frame_t_ns) - 1, frames).astype(int)
    T_w_b = setup.trajectory.states(setup.frame_t_ns[picks]).T_w_b
    images = []
    with StereoCamera(setup.scene, setup.rig, vehicle=c.vehicle, rgb=c.rgb) as camera:
        for j, k in enumerate(picks):
            imgs, _, _ = camera.measure(T_w_b[j], setup.scene.actor_states(int(setup.frame_t_ns[k])))
            images += add_noise(imgs, setup.image_noise, indexed_stream(c.seed, "image_noise", int(k)))
    settings = [PngOptions(level, strategy, "all") for strategy in PNG_STRATEGIES for level in range(10)]
    settings += [PngOptions(1, PNG_STRATEGY, f) for f in PNG_FILTERS]
    rows = []
    for png in settings:
        t0 = time.process_time()
        sizes = [len(encode_png(img, png=png)) for img in images]
        dt = time.process_time() - t0
        rows.append({"strategy": png.strategy, "level": png.compression, "filter": png.filter,
                     "kb_per_image": float(np.mean(sizes)) / 1024.0, "encode_ms_per_image": 1e3 * dt / len(images)})
    return rows


def noise_cost(width: int = 752, height: int = 480, sigma: float = 1.0, pairs: int = 200, rounds: int = 3) -> dict:
    """CPU ms per stereo pair of ``width x height`` grey images for the camera's noise step
    (:func:`rigs.image_noise.add_quantized_noise`) and for the Gaussian sum in float32 and float64
    (:func:`rigs.image_noise.add_image_noise`), each frame from its own indexed stream (its creation
    included), one thread; after one warm-up pair, the least of ``rounds`` rounds of ``pairs`` pairs
    (process CPU time: other processes' load inflates it, never lowers it)."""
    img = np.random.default_rng(0).integers(0, 256, (height, width), dtype=np.uint8)
    draws = {"quantized offsets (camera)": add_quantized_noise,
             "gaussian sum, float32": lambda im, s, rng: add_image_noise(im, s, rng, np.float32),
             "gaussian sum, float64": lambda im, s, rng: add_image_noise(im, s, rng, np.float64)}
    out, cv_threads = {}, cv2.getNumThreads()
    cv2.setNumThreads(1)                   # one thread, as in the frame pipeline's workers
    try:
        for name, draw in draws.items():
            def pair(k, draw=draw):
                rng = indexed_stream(0, "image_noise", k)
                draw(img, sigma, rng), draw(img, sigma, rng)
            out[name] = _best_cpu_ms(pair, pairs, rounds)
    finally:
        cv2.setNumThreads(cv_threads)
    return out


def _best_cpu_ms(draw_pair, pairs: int, rounds: int) -> float:
    """Least over ``rounds`` of the CPU ms per call of ``draw_pair(k)`` (two images), ``pairs`` calls each."""
    draw_pair(0)
    best = float("inf")
    for _ in range(rounds):
        t0 = time.process_time()
        for k in range(pairs):
            draw_pair(k)
        best = min(best, 1e3 * (time.process_time() - t0) / pairs)
    return best


def format_bench(b: GenerateBench) -> str:
    lines = [f"scenario {b.scenario}: {b.frames} pairs, {b.workers} render process(es), {b.threads} worker threads, "
             f"PNG {b.png}, "
             f"{b.cpus} CPUs, load {b.load_avg[0]:.2f} -> {b.load_avg[1]:.2f}",
             f"render only   {b.render_pairs_per_s:7.1f} pairs/s   (CPU {b.render_cpu_ms:.1f} ms/pair, all threads)",
             f"end to end    {b.end_to_end_pairs_per_s:7.1f} pairs/s   "
             f"(CPU {b.end_to_end_cpu_ms:.1f} ms/pair, all threads)",
             f"ratio         {b.ratio:7.2f}",
             *([f"after start-up {b.after_start_pairs_per_s:6.1f} pairs/s   (workers' first chunk in; ratio "
                f"{b.after_start_pairs_per_s / b.render_pairs_per_s:.2f})"] if b.after_start_pairs_per_s else []),
             *([f"start-up      world here {b.startup_s['world_build']:.2f} s (CPU "
                f"{b.startup_s['world_build_cpu']:.2f}), per worker {b.startup_s['worker_mean']:.2f} s (CPU "
                f"{b.startup_s['worker_mean_cpu']:.2f}, mean), first chunk in after {b.startup_s['first_chunk']:.2f} s, "
                f"a worker's after {b.startup_s['first_worker_chunk']:.2f} s; {b.startup_s['frames_here']} frames "
                f"rendered here (GL context {b.startup_s['here_startup']:.2f} s)"]
               if b.startup_s else []),
             *([f"start-up parts (s, mean per worker; 'here': this process) " + ", ".join(
                 f"{k.replace('start-up', '').strip(': ') or 'worker'}: {v:.2f}" for k, v in b.startup_s["parts"].items())]
               if b.startup_s.get("parts") else []),
             *([f"world         {b.world['cache']} ("
                f"{'loaded from' if b.world['cache'] == 'hit' else 'built, not in'} the world cache): "
                f"{b.world['seconds']:.2f} s (CPU {b.world['cpu_s']:.2f})"] if b.world else []),
             "stage ms/pair " + "  ".join(f"{s} {b.stage_ms[s]:.1f}" for s in STAGES),
             f"peak memory   {b.peak_rss_mb:7.0f} MB" + (f" (largest worker process {b.peak_rss_children_mb:.0f} MB)"
                                                     if b.workers > 1 else ""),
             f"renderer      {b.renderer}"]
    lines += [f"end to end on {r}" for r in b.end_to_end_renderers if r != b.renderer]
    return "\n".join(lines)


def format_levels(rows: list) -> str:
    out = [f"{'strategy':>8} {'level':>5} {'filter':>6} {'KB/image':>9} {'encode CPU ms/image':>20}"]
    out += [f"{r['strategy']:>8} {r['level']:>5} {r['filter']:>6} {r['kb_per_image']:9.1f} "
            f"{r['encode_ms_per_image']:20.2f}" for r in rows]
    return "\n".join(out)
