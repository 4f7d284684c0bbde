"""Calibrate the `realistic` preset's sensor noise against real EuRoC frames, and check it on our renders.

For every folder of 8-bit grey PNG frames given, the noise level per brightness bin
(:func:`vo.frontend.noise_level.noise_level_curve`, Immerkaer on the flattest pixels of each bin, clipped
pixels left out) is taken on every ``--step``-th frame; the table prints each bin's median over frames.
The folders named with ``--real`` are pooled and fitted with the shot + read noise model
(:func:`vo.frontend.noise_level.fit_shot_read_noise`, ``sigma^2 = K S + r^2 + 1/12``): the ``K`` and ``r``
the preset (`sim/sensors/effects_presets.py`) takes. ``--plot`` draws the curves with the fitted model.

    python docs/studies/euroc_noise_calibration.py --real V1_01_easy/mav0/cam0/data --real V1_01_easy/mav0/cam1/data \\
        --ours CAMPUS_REALISTIC/mav0/cam0/data --ours INDOOR_REALISTIC/mav0/cam0/data --plot noise_curves.png
"""
from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from sim.sensors.effects_presets import REALISTIC_CAMERA
from vo.frontend.noise_level import fit_shot_read_noise, noise_level_curve


def curve_samples(folder: Path, step: int):
    """All (level, sigma) samples of the folder's frames 0, step, 2 step, ...; and the median curve."""
    frames = sorted(folder.glob("*.png"))[::step]
    if not frames:
        raise SystemExit(f"error: {folder}: no PNG frames")
    levels, sigmas = [], []
    for f in frames:
        lv, sg, _ = noise_level_curve(cv2.imread(str(f), cv2.IMREAD_GRAYSCALE))
        levels += list(lv)
        sigmas += list(sg)
    levels, sigmas = np.array(levels), np.array(sigmas)
    grid = np.unique(levels)
    return levels, sigmas, grid, np.array([np.median(sigmas[levels == v]) for v in grid]), len(frames)


def model_sigma(levels, gain, read):
    return np.sqrt(gain * np.asarray(levels) + read ** 2 + 1.0 / 12.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", type=Path, action="append", default=[], help="folder of real frames (pooled, fitted)")
    ap.add_argument("--ours", type=Path, action="append", default=[], help="folder of rendered frames")
    ap.add_argument("--step", type=int, default=3)
    ap.add_argument("--plot", type=Path)
    a = ap.parse_args()
    curves, pooled = {}, ([], [])
    for kind, folders in (("real", a.real), ("ours", a.ours)):
        for folder in folders:
            lv, sg, grid, med, n = curve_samples(folder, a.step)
            curves[f"{kind}: {folder}"] = (grid, med)
            print(f"{kind} {folder} ({n} frames): " + " ".join(f"{g:.0f}:{m:.2f}" for g, m in zip(grid, med)))
            if kind == "real":
                pooled[0].extend(lv)
                pooled[1].extend(sg)
    preset = (REALISTIC_CAMERA.shot_noise_gain, REALISTIC_CAMERA.read_noise_dn)
    if pooled[0]:
        gain, read = fit_shot_read_noise(*pooled)
        print(f"fit to the real frames: shot_noise_gain K = {gain:.4f} grey levels/e-, read_noise_dn r = {read:.3f}")
    print(f"preset: K = {preset[0]:.4f}, r = {preset[1]:.3f}")
    for name, (grid, med) in curves.items():
        ratio = med / model_sigma(grid, *preset)
        print(f"  {name}: measured / preset model per bin " + " ".join(f"{r:.2f}" for r in ratio))
    if a.plot:
        _plot(curves, preset, a.plot)


def _label(name: str) -> str:
    """``kind: .../NAME/mav0/cam0/data`` -> ``kind: NAME cam0``."""
    kind, folder = name.split(": ", 1)
    parts = [p for p in Path(folder).parts if p not in ("data", "mav0")]
    return f"{kind}: " + " ".join(parts[-2:])


def _plot(curves, preset, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for name, (grid, med) in curves.items():
        ax.plot(grid, med, "o-" if name.startswith("real") else "s--", ms=4, label=_label(name))
    s = np.linspace(0, 255, 100)
    ax.plot(s, model_sigma(s, *preset), "k-", lw=2, label=f"preset K={preset[0]:.4f}, r={preset[1]:.2f}")
    ax.set_xlabel("local mean (grey levels)")
    ax.set_ylabel("Immerkaer noise std (grey levels)")
    ax.grid(alpha=.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
