"""Predictions for a rig: range error against range (eq. 7 and the general triangulation model)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vo.errors import VoError
from vo.errorprop.range import range_sigma
from vo.errorprop.triangulation import triangulation_covariance


def parse_ranges(text: str) -> np.ndarray:
    """``"5,10,20"`` or ``"start:stop[:step]"`` (stop inclusive, step default 1) -> (N,) metres."""
    try:
        if ":" in text:
            parts = [float(p) for p in text.split(":")]
            if len(parts) not in (2, 3):
                raise ValueError
            start, stop = parts[0], parts[1]
            step = parts[2] if len(parts) == 3 else 1.0
            if step <= 0 or stop < start:
                raise ValueError
            values = np.arange(start, stop + step * 1e-9, step)
        else:
            values = np.array([float(p) for p in text.split(",") if p.strip()])
    except ValueError:
        raise VoError(f"ranges: expected a list '5,10,20' or 'start:stop[:step]', got {text!r}") from None
    if values.size == 0 or np.any(values <= 0) or not np.all(np.isfinite(values)):
        raise VoError(f"ranges: ranges must be positive finite metres, got {text!r}")
    return values


@dataclass(frozen=True)
class RangePrediction:
    rig: str
    baseline_m: float
    f_px: float
    sigma_p_px: float
    ranges_m: np.ndarray = field(repr=False)
    sigma_normal_case_m: np.ndarray = field(repr=False)      # seed 001 eq. 7
    sigma_triangulation_m: np.ndarray = field(repr=False)    # general first-order, along cam0's axis

    def to_dict(self) -> dict:
        return {"rig": self.rig, "baseline_m": self.baseline_m, "f_px": self.f_px, "sigma_p_px": self.sigma_p_px,
                "rows": [{"range_m": float(r), "sigma_eq7_m": float(a), "sigma_triangulation_m": float(b)}
                         for r, a, b in zip(self.ranges_m, self.sigma_normal_case_m, self.sigma_triangulation_m)]}

    def table(self) -> str:
        lines = [f"rig {self.rig}: baseline {self.baseline_m:.4f} m, f {self.f_px:.1f} px, "
                 f"parallax error sigma_p {self.sigma_p_px:.3f} px",
                 f"{'range (m)':>10} {'eq.7 (m)':>10} {'triang. (m)':>12} {'eq.7 (%)':>9}"]
        for r, a, b in zip(self.ranges_m, self.sigma_normal_case_m, self.sigma_triangulation_m):
            lines.append(f"{r:10.2f} {a:10.4f} {b:12.4f} {100 * a / r:9.3f}")
        return "\n".join(lines)


def predict_range(rig, ranges_m, sigma_p_px: float = 1.0 / 3.0) -> RangePrediction:
    """Range error of points straight ahead of the left camera.

    ``sigma_p_px`` is the parallax (disparity) error of eq. 7; the triangulation model gets the
    equivalent per-image pixel error ``sigma_p / sqrt(2)`` in each camera (isotropic). A
    ``sigma_p_px`` that is not a positive number raises VoError (a negative one would print
    negative errors).
    """
    if not (isinstance(sigma_p_px, (int, float)) and np.isfinite(sigma_p_px) and sigma_p_px > 0):
        raise VoError(f"sigma_p_px: must be a positive number of pixels, got {sigma_p_px!r}")
    c0, c1 = rig.cameras[0], rig.cameras[1]
    T_c0_c1 = rig.T_c0_c1
    f = float(c0.fx)
    ranges = np.asarray(ranges_m, dtype=float)
    tri = np.array([np.sqrt(triangulation_covariance(c0.K, c1.K, T_c0_c1, np.array([0.0, 0.0, r]),
                                                     sigma_p_px / np.sqrt(2))[2, 2]) for r in ranges])
    return RangePrediction(rig.name, rig.baseline, f, sigma_p_px, ranges,
                           range_sigma(ranges, rig.baseline, f, sigma_p_px), tri)


def plot_range_prediction(pred: RangePrediction, path, measured=None) -> None:
    """Predicted range error against range; ``measured`` optional dict label -> (ranges, sigmas)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.plot(pred.ranges_m, pred.sigma_normal_case_m, "k-", label="eq. 7 (normal case)")
    ax.plot(pred.ranges_m, pred.sigma_triangulation_m, "b--", label="triangulation covariance")
    for label, (r, s) in (measured or {}).items():
        ax.plot(r, s, "o", label=label)
    ax.set_xlabel("range (m)")
    ax.set_ylabel("1-sigma range error (m)")
    ax.set_title(f"{pred.rig}: b = {pred.baseline_m:.3f} m, f = {pred.f_px:.0f} px, sigma_p = {pred.sigma_p_px:.2f} px")
    ax.grid(True, alpha=0.3)
    ax.legend()
    _save(fig, path)


def plot_cross_site(cfg, result, path) -> None:
    """Top-down layout of sites and landmarks with the 1-sigma ellipse of the new site (x20)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.5, 4))
    lm = np.asarray(cfg.landmarks)
    ax.plot(*lm.T, "r^", label="tie points")
    ax.plot(*cfg.previous_site, "ks", label="previous site")
    ax.plot(*cfg.current_site, "bs", label="current site")
    w, V = np.linalg.eigh(result.M_p)
    t = np.linspace(0, 2 * np.pi, 100)
    ell = (V @ np.diag(np.sqrt(w)) @ np.stack([np.cos(t), np.sin(t)])) * 20 + np.asarray(cfg.current_site)[:, None]
    ax.plot(*ell, "b-", label="1-sigma x20")
    ax.set_aspect("equal")
    ax.set_title(f"cross-site accuracy {result.accuracy_percent:.2f}% of {result.distance_m:.1f} m")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    _save(fig, path)


def _save(fig, path) -> None:
    from vo.eval.plots import save_figure
    save_figure(fig, path)
