"""`vins` fed a camera-IMU time offset it does not model: generate, run, tabulate, plot.

For each seed and each offset ``td`` (``imu.time_offset_ms``: every IMU stamp is ``t_true + td``):

    vo-testbed generate --scene campus --rig cart27 --duration 30 --seed S --set imu.time_offset_ms=TD --out D
    OPENBLAS_NUM_THREADS=1 vo-testbed run --dataset D --estimator vins --out R
    vo-testbed eval --gt D --est R/post_init_tum.txt --align first --json

"after init" figures are those of docs/vins.md: the poses whose status is not ``init``, aligned at the first
of them. The first-order prediction (module :func:`route_rates` and docs/sensor_effects.md) comes from the
ground truth of the ``td = 0`` dataset. Datasets and runs are kept under ``--work`` and reused when complete,
so a re-run only redraws the table and the plot.

    nice -n 5 .venv/bin/python docs/studies/vins_time_offset.py --work /tmp/vins_td
    .venv/bin/python docs/studies/vins_time_offset.py --work /tmp/vins_td --timeline 0:10,0:20,0:-20,1:10
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FIG_DIR = ROOT / "docs" / "studies" / "figures" / "vins_time_offset"
BIN = Path(sys.executable).parent / "vo-testbed"


def sh(args: list, log: Path) -> None:
    """Run one command (one BLAS thread), its output to ``log``; stop the study if it fails."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    with open(log, "w") as f:
        rc = subprocess.call([str(a) for a in args], stdout=f, stderr=subprocess.STDOUT, env=env)
    if rc != 0:
        raise SystemExit(f"error: {' '.join(map(str, args))} exited {rc}; see {log}")


def generate(work: Path, seed: int, td_ms: float, duration: float) -> Path:
    d = work / f"s{seed}_td{td_ms:g}"
    if not (d / "metadata.yaml").is_file() or (d / "INCOMPLETE").exists():
        sh([BIN, "generate", "--scene", "campus", "--rig", "cart27", "--duration", duration, "--seed", seed,
            "--set", f"imu.time_offset_ms={td_ms:g}", "--out", d, "--no-progress"], work / f"{d.name}.gen.log")
    return d


def run_vins(work: Path, dataset: Path) -> Path:
    r = work / f"run_{dataset.name}"
    n_frames = sum(1 for ln in open(dataset / "mav0" / "cam0" / "data.csv") if not ln.startswith("#"))
    if not (r / "summary.json").is_file():      # the last frame is left out: with td < 0 no IMU reaches it
        sh([BIN, "run", "--dataset", dataset, "--estimator", "vins", "--out", r, "--no-progress",
            "--max-frames", n_frames - 1], work / f"{r.name}.log")
    return r


def post_init(run: Path) -> tuple:
    """Write ``post_init_tum.txt`` (poses whose status is not ``init``); -> (frame index of the first, count)."""
    status = [row["status"] for row in csv.DictReader(open(run / "frames.csv"))]
    lines = [ln for ln in open(run / "trajectory_tum.txt") if ln.strip() and not ln.startswith("#")]
    if len(lines) != len(status):
        raise SystemExit(f"error: {run}: {len(lines)} poses but {len(status)} rows in frames.csv")
    keep = [ln for ln, s in zip(lines, status) if s != "init"]
    (run / "post_init_tum.txt").write_text("".join(keep))
    first = next((k for k, s in enumerate(status) if s != "init"), None)
    return first, len(keep)


def evaluate(dataset: Path, est: Path, work: Path) -> dict:
    out = work / f"{est.parent.name}.{est.stem}.eval.json"
    if not out.is_file():
        sh([BIN, "eval", "--gt", dataset, "--est", est, "--align", "first", "--json"], out)
    text = out.read_text()
    return json.loads(text[text.index("{"):])


def route_rates(dataset: Path) -> dict:
    """What sets the size of an unmodelled td, from the 200 Hz ground truth: yaw rate, angular acceleration
    ``alpha``, the rate of change of the specific force ``f = R^T (a - g)`` in the body frame, the motion
    acceleration ``a``, and the rig's Kalibr noise densities."""
    import yaml
    from scipy.spatial.transform import Rotation
    gt = np.loadtxt(dataset / "mav0" / "state_groundtruth_estimate0" / "data.csv", delimiter=",", comments="#")
    dt = float(np.median(np.diff(gt[:, 0]))) * 1e-9
    R_w_i = Rotation.from_quat(gt[:, [5, 6, 7, 4]])                        # xyzw from wxyz
    omega_i = (R_w_i[:-1].inv() * R_w_i[1:]).as_rotvec() / dt              # body-frame rate, rad/s
    alpha_i = np.diff(omega_i, axis=0) / dt
    a_w = np.diff(gt[:, 8:11], axis=0) / dt
    f_i = R_w_i[:-1].inv().apply(a_w + np.array([0.0, 0.0, 9.81]))
    fdot_i = np.diff(f_i, axis=0) / dt
    moving = np.linalg.norm(gt[:-2, 8:11], axis=1) > 0.5                   # cruise: where the scale is kept
    imu = yaml.safe_load((dataset / "metadata.yaml").read_text())["rig"]["imu"]
    rms = lambda x: float(np.sqrt(np.mean(np.sum(x ** 2, axis=1))))         # noqa: E731
    return dict(yaw_max=float(np.abs(omega_i[:, 2]).max()), alpha_max=float(np.linalg.norm(alpha_i, axis=1).max()),
                fdot_rms=rms(fdot_i[moving]), accel_rms=rms(a_w[:-1][moving]),
                gyro_nd=float(imu["gyro_noise_density"]), accel_nd=float(imu["accel_noise_density"]),
                fx=float(yaml.safe_load((dataset / "metadata.yaml").read_text())["rig"]["cameras"][0]["fx"]))


def prediction_table(r: dict, offsets: list) -> str:
    """First order: the IMU reads omega(t - td) ~ omega - td alpha and f(t - td) ~ f - td f'. Those errors,
    beside the IMU's own noise averaged over 1 s (the noise density), and the camera-IMU attitude mismatch
    omega td in turns, in pixels (docs/sensor_effects.md)."""
    lines = ["| td ms | gyro error td·α_max (rad/s) | / gyro noise over 1 s | accel error td·rms(ḟ) (m/s²) | "
             "/ accel noise over 1 s | / rms motion acceleration | attitude mismatch f·ω_max·td (px) |",
             "|---|---|---|---|---|---|---|"]
    for td in offsets:
        s = abs(td) * 1e-3
        g, a = s * r["alpha_max"], s * r["fdot_rms"]
        lines.append(f"| {td:g} | {g:.2e} | {g / r['gyro_nd']:.0f} | {a:.2e} | {a / r['accel_nd']:.1f} | "
                     f"{100 * a / r['accel_rms']:.1f} % | {r['fx'] * r['yaw_max'] * s:.2f} |")
    return "\n".join(lines)


def one_cell(work: Path, seed: int, td_ms: float, duration: float) -> dict:
    d = generate(work, seed, td_ms, duration)
    r = run_vins(work, d)
    summary = json.loads((r / "summary.json").read_text())
    metrics = json.loads((r / "metrics.json").read_text())["metrics"]
    first, n_post = post_init(r)
    row = dict(seed=seed, td_ms=td_ms, init_frame=first, n_post=n_post, n_lost=summary["n_lost"],
               drift_all_pct=metrics["drift"]["drift_ratio_pct"])
    if n_post >= 2:
        ev = evaluate(d, r / "post_init_tum.txt", work)
        row.update(drift_pct=ev["drift"]["drift_ratio_pct"], ate_m=ev["ape"]["trans_m"]["rmse"],
                   rot_deg=ev["ape"]["rot_deg"]["rmse"], path_m=ev["drift"]["gt_length_m"],
                   length_pct=100.0 * ev["drift"]["length_diff_m"] / ev["drift"]["gt_length_m"])
    return row


def results_table(rows: list) -> str:
    lines = ["| seed | td ms | init at frame | drift % all | drift % after init | ATE rmse m after init | "
             "rot rmse deg after init | path length error % after init |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r.get("drift_pct") is None:
            lines.append(f"| {r['seed']} | {r['td_ms']:g} | never | {r['drift_all_pct']:.2f} | - | - | - | - |")
            continue
        lines.append(f"| {r['seed']} | {r['td_ms']:g} | {r['init_frame']} | {r['drift_all_pct']:.2f} | "
                     f"{r['drift_pct']:.2f} | {r['ate_m']:.3f} | {r['rot_deg']:.3f} | {r['length_pct']:+.1f} |")
    return "\n".join(lines)


def plot(rows: list, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for seed in sorted({r["seed"] for r in rows}):
        rs = sorted((r for r in rows if r["seed"] == seed and r.get("drift_pct") is not None),
                    key=lambda r: r["td_ms"])
        td = [r["td_ms"] for r in rs]
        axes[0].plot(td, [r["drift_pct"] for r in rs], "o-", label=f"seed {seed}")
        axes[1].plot(td, [r["ate_m"] for r in rs], "o-", label=f"seed {seed}")
    axes[0].set_ylabel("drift after init (%)")
    axes[1].set_ylabel("ATE rmse after init (m)")
    for ax in axes:
        ax.set_xlabel("unmodelled IMU time offset td (ms)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle("vins on campus (30 s, cart27), IMU stamps t + td")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def timeline(work: Path, seed: int, td_ms: float) -> str:
    """Per second after init: position error (aligned at the first post-init pose) and the estimated over the
    true distance travelled in the +-0.5 s around it (the speed ratio)."""
    from scipy.spatial.transform import Rotation

    def load(path):
        d = np.loadtxt(path, comments="#")
        return d[:, 0], d[:, 1:4], Rotation.from_quat(d[:, 4:8])
    t_g, p_g, R_g = load(work / f"s{seed}_td{td_ms:g}" / "groundtruth_tum.txt")
    t, p, R = load(work / f"run_s{seed}_td{td_ms:g}" / "post_init_tum.txt")
    g = np.searchsorted(t_g, t - 1e-6)
    p_e = (R_g[g[0]] * R[0].inv()).apply(p - p[0]) + p_g[g[0]]
    err = np.linalg.norm(p_e - p_g[g], axis=1)
    step_e, step_g = (np.linalg.norm(np.diff(x, axis=0), axis=1) for x in (p_e, p_g[g]))
    out = []
    for k in range(0, len(t), 10):
        w = slice(max(k - 5, 0), k + 5)
        out.append(f"{t[k]:.0f} s: {err[k]:.2f} m, x{step_e[w].sum() / step_g[w].sum():.3f}")
    return f"seed {seed}, td {td_ms:g} ms: " + "; ".join(out)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, default=Path("/tmp/vins_time_offset"), help="datasets and runs")
    p.add_argument("--seeds", default="0,1")
    p.add_argument("--offsets", default="0,1,2,5,10,20,50,-20", help="td values in ms")
    p.add_argument("--duration", type=float, default=30.0)
    p.add_argument("--figure", type=Path, default=FIG_DIR / "drift_vs_td.png")
    p.add_argument("--timeline", default="", help="SEED:TD,...: per-second error and speed ratio of those runs")
    a = p.parse_args(argv)
    if a.timeline:
        for item in a.timeline.split(","):
            seed, td = item.split(":")
            print(timeline(a.work, int(seed), float(td)))
        return
    a.work.mkdir(parents=True, exist_ok=True)
    seeds = [int(s) for s in a.seeds.split(",")]
    offsets = [float(x) for x in a.offsets.split(",")]
    rows = []
    for seed in seeds:
        for td in offsets:
            rows.append(one_cell(a.work, seed, td, a.duration))
            print(json.dumps(rows[-1]), flush=True)
    rates = route_rates(generate(a.work, seeds[0], 0.0, a.duration))
    (a.work / "results.json").write_text(json.dumps(dict(rows=rows, route=rates), indent=1))
    print("route:", {k: round(v, 4) for k, v in rates.items()})
    print(prediction_table(rates, [td for td in offsets if td > 0]))
    print()
    print(results_table(sorted(rows, key=lambda r: (r["td_ms"], r["seed"]))))
    plot(rows, a.figure)
    print(f"figure: {a.figure}")


if __name__ == "__main__":
    main()
