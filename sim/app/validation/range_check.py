"""Validate seed 001 eq. 7 (``sigma_r = r^2 sigma_p / (b f)``) on rendered stereo images.

Procedure, per baseline ``b`` (the ``stereo27`` rig with ``baseline=b``, c0 fixed) and per range
``r``: render one frame of :mod:`sim.app.validation.targets` (a fronto-parallel textured board at depth
exactly ``r`` on c0's optical axis), add seeded Gaussian image noise to both grey images, match
left -> right with each matcher, and compare with the exact disparity from the rendered depth,
``d_true = f b / Z`` at the left pixel (parallel rectified rig: ``d = u0 - u1``).

Statistics (robust, documented choices):

* gross outliers: ``|d_meas - d_true| > outlier_px`` (3 px), reported as a rate, then dropped;
* ``sigma_p`` per (baseline, matcher): ``1.4826 * median(|e|)`` of the inlier disparity errors
  ``e = d_meas - d_true`` pooled over all ranges. The scale is taken *about the truth*, not about
  the median, so a systematic disparity bias counts as error (eq. 7 is about total range error);
* measured ``sigma_r`` per range: ``1.4826 * median(|Z_meas - Z_true|)`` with ``Z_meas = f b / d_meas``
  over the same inliers (median-based because ``1/d`` is skewed where ``sigma_p / d`` is not small);
* predicted ``sigma_r``: eq. 7 with that measured ``sigma_p`` (:func:`vo.errorprop.range.range_sigma`).

What can legitimately make them disagree (reported, not hidden): (1) SGBM's parabola sub-pixel
fit is biased towards integer disparities ("pixel locking"); on a fronto-parallel board all pixels
share one true disparity, so the error of a range bin is dominated by a bias that depends on
``frac(d_true)`` and is *not* range independent; (2) disparity errors of neighbouring pixels are
strongly correlated (SGBM smoothing, overlapping KLT windows), so the effective sample size is far
below ``n`` and the sampling error of a bin's scale is larger than ``1.17 / sqrt(n)``; (3) at small
disparities eq. 7's first-order linearisation fails (``Z = f b / d`` is convex in ``d``), and bins
with ``d_true`` below ~``5 sigma_p`` are skewed; (4) rendering is not noise: without added noise
the error comes from texture resampling and is deterministic per pixel. Boards subtend a fixed
angle, so the texture has the same pixel scale at every range (no foreshortening, same gradient
energy per matching window) - the premise of a range-independent ``sigma_p``.
"""
from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass

import cv2
import numpy as np

from rigs.image_noise import add_image_noise
from rigs.overrides import apply_overrides
from rigs.presets import get_rig
from scenes.base import SceneConfig
from sim.errors import SimError
from sim.rng import stream
from vo.errorprop.range import range_sigma

MATCHERS = ("klt", "sgbm")
MAD_TO_SIGMA = 1.4826           # Gaussian: sigma = 1.4826 * median(|x|) for zero-mean x


# ----------------------------------------------------------------------------- result types
@dataclass(frozen=True)
class MatcherFit:
    """Measured parallax error of one matcher at one baseline (pooled over ranges)."""

    baseline_m: float
    matcher: str
    sigma_p_px: float
    n: int
    outlier_rate: float


@dataclass(frozen=True)
class BinResult:
    """One (baseline, matcher, range) bin; ``ratio = measured / predicted``."""

    baseline_m: float
    matcher: str
    range_m: float
    d_true_px: float
    n: int
    n_outliers: int
    sigma_p_bin_px: float
    bias_px: float
    predicted_sigma_r_m: float
    measured_sigma_r_m: float

    @property
    def ratio(self) -> float:
        return self.measured_sigma_r_m / self.predicted_sigma_r_m if self.predicted_sigma_r_m > 0 else float("nan")


@dataclass(frozen=True)
class RangeValidation:
    """All fits and bins; ``passed``: every bin with ``n >= min_samples`` has ``|ratio-1| <= tolerance``."""

    rig: str
    f_px: float
    image_noise: float
    seed: int
    min_samples: int
    tolerance: float
    fits: tuple
    bins: tuple

    def bins_for(self, baseline_m: float, matcher: str) -> list:
        return [b for b in self.bins if b.baseline_m == baseline_m and b.matcher == matcher]

    def fit(self, baseline_m: float, matcher: str) -> MatcherFit:
        return next(f for f in self.fits if f.baseline_m == baseline_m and f.matcher == matcher)

    def bin_ok(self, b: BinResult) -> bool:
        return b.n >= self.min_samples and abs(b.ratio - 1.0) <= self.tolerance

    @property
    def passed(self) -> bool:
        return all(self.bin_ok(b) for b in self.bins if b.n >= self.min_samples)

    def to_dict(self) -> dict:
        return {"rig": self.rig, "f_px": self.f_px, "image_noise": self.image_noise, "seed": self.seed,
                "min_samples": self.min_samples, "tolerance": self.tolerance, "passed": self.passed,
                "fits": [_json_safe(asdict(f)) for f in self.fits],
                "bins": [_json_safe(dict(asdict(b), ratio=b.ratio, ok=self.bin_ok(b))) for b in self.bins]}

    def table(self) -> str:
        lines = [f"rig {self.rig}, f {self.f_px:.1f} px, image noise {self.image_noise:g} grey levels, "
                 f"seed {self.seed}; pass if |ratio-1| <= {self.tolerance:.0%} where n >= {self.min_samples}"]
        for f in self.fits:
            lines.append("")
            lines.append(f"baseline {f.baseline_m:.3f} m, {f.matcher}: sigma_p {f.sigma_p_px:.4f} px "
                         f"(n {f.n}, outliers {100 * f.outlier_rate:.1f}%)")
            lines.append(f"{'range':>6} {'d_true':>7} {'n':>6} {'out':>5} {'sig_p':>7} {'bias':>7} "
                         f"{'pred (m)':>10} {'meas (m)':>10} {'ratio':>6}")
            for b in self.bins_for(f.baseline_m, f.matcher):
                flag = "" if b.n < self.min_samples else ("  ok" if self.bin_ok(b) else "  FAIL")
                lines.append(f"{b.range_m:6.1f} {b.d_true_px:7.2f} {b.n:6d} {b.n_outliers:5d} {b.sigma_p_bin_px:7.4f} "
                             f"{b.bias_px:+7.4f} {b.predicted_sigma_r_m:10.5f} {b.measured_sigma_r_m:10.5f} "
                             f"{b.ratio:6.2f}{flag}")
        lines.append("")
        lines.append("PASS" if self.passed else "FAIL")
        return "\n".join(lines)

    def write(self, out_dir) -> dict:
        """Write ``range_validation.json`` and ``range_validation.png`` into ``out_dir``; return paths."""
        os.makedirs(out_dir, exist_ok=True)
        paths = {"json": os.path.join(out_dir, "range_validation.json"),
                 "plot": os.path.join(out_dir, "range_validation.png")}
        with open(paths["json"], "w") as fh:
            json.dump(self.to_dict(), fh, indent=2, sort_keys=True)
        plot_range_validation(self, paths["plot"])
        return paths


def _json_safe(d: dict) -> dict:
    """NaN (empty bins) -> None so the dict is strict JSON."""
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in d.items()}


# ----------------------------------------------------------------------------- statistics
def robust_scale(x: np.ndarray) -> float:
    """``1.4826 * median(|x|)``: Gaussian sigma of zero-mean ``x`` (scale about 0, bias included)."""
    x = np.asarray(x, float)
    return float(MAD_TO_SIGMA * np.median(np.abs(x))) if x.size else float("nan")


def disparity_from_depth(depth_m: np.ndarray, f_px: float, baseline_m: float) -> np.ndarray:
    """Exact disparity (px) of a parallel rectified pair from c0's depth along the optical axis."""
    return f_px * baseline_m / np.asarray(depth_m, np.float64)


def board_mask(depth_m: np.ndarray, range_m: float, margin_px: int) -> np.ndarray:
    """(H,W) bool: pixels on the board face (depth within 0.1% of ``range_m``), eroded by
    ``margin_px`` so a matching window centred there lies wholly on the board."""
    on = (np.abs(depth_m - range_m) <= 1e-3 * range_m).astype(np.uint8)
    k = 2 * int(margin_px) + 1
    return cv2.erode(on, np.ones((k, k), np.uint8), borderValue=0).astype(bool)


# ----------------------------------------------------------------------------- matchers
def klt_disparities(left: np.ndarray, right: np.ndarray, mask: np.ndarray, win: int = 21, levels: int = 4,
                    fb_px: float = 1.0, max_corners: int = 400, min_distance: float = 7.0) -> tuple:
    """Shi-Tomasi corners in ``mask`` of the grey ``left``, pyramidal LK left -> right and back.

    ``levels`` counts the full-resolution level (OpenCV ``maxLevel = levels - 1``). Returns
    ``(p_left (N,2) px, d (N,) = u_left - u_right px, ok (N,) bool)`` with ``ok`` = LK status of both
    passes and forward-backward error <= ``fb_px``.
    """
    pts = cv2.goodFeaturesToTrack(left, maxCorners=max_corners, qualityLevel=0.01, minDistance=min_distance,
                                  mask=mask.astype(np.uint8) * 255, blockSize=3)
    if pts is None:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool)
    p0 = pts.astype(np.float32).reshape(-1, 1, 2)
    lk = dict(winSize=(win, win), maxLevel=levels - 1,
              criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 0.001))
    p1, st1, _ = cv2.calcOpticalFlowPyrLK(left, right, p0, None, **lk)
    p0b, st2, _ = cv2.calcOpticalFlowPyrLK(right, left, p1, None, **lk)
    fb = np.linalg.norm((p0b - p0).reshape(-1, 2), axis=1)
    ok = (st1.ravel() == 1) & (st2.ravel() == 1) & (fb <= fb_px)
    p0, p1 = p0.reshape(-1, 2).astype(np.float64), p1.reshape(-1, 2).astype(np.float64)
    return p0, p0[:, 0] - p1[:, 0], ok


def sgbm_disparity_map(left: np.ndarray, right: np.ndarray, max_disparity_px: float, block: int = 5) -> np.ndarray:
    """(H,W) float disparity (px) from ``cv2.StereoSGBM`` (fixed-point /16); NaN where invalid.

    ``numDisparities`` is the next multiple of 16 above ``1.25 * max_disparity_px + 8``.
    """
    num = int(16 * np.ceil((1.25 * max_disparity_px + 8) / 16))
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num, blockSize=block,
                                 P1=8 * block * block, P2=32 * block * block, disp12MaxDiff=1,
                                 uniquenessRatio=10, speckleWindowSize=0, speckleRange=0,
                                 mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)
    raw = sgbm.compute(left, right)
    d = raw.astype(np.float64) / 16.0
    d[raw < 0] = np.nan
    return d


def sgbm_disparities(left, right, mask, max_disparity_px: float, block: int = 5, stride: int = 1) -> tuple:
    """Dense SGBM disparities at ``mask`` pixels (every ``stride``-th row/column) -> ``(p (N,2), d, ok)``."""
    dmap = sgbm_disparity_map(left, right, max_disparity_px, block)
    sub = np.zeros_like(mask)
    sub[::stride, ::stride] = True
    v, u = np.nonzero(mask & sub)
    d = dmap[v, u]
    return np.column_stack([u, v]).astype(np.float64), np.nan_to_num(d, nan=-1.0), np.isfinite(d)


# ----------------------------------------------------------------------------- rendering
def render_board_frames(rig, ranges_m, seed: int = 0, half_angles_deg=(10.0, 7.0)) -> list:
    """Render one stereo frame per range -> ``[(left grey uint8, right grey uint8, depth_c0 float32 m)]``."""
    from sim.world import build_world
    from sim.render import StereoRenderer
    from sim.app.validation.targets import TargetScene, board_layout
    boards, poses = board_layout(rig, ranges_m, half_angles_deg=half_angles_deg, seed=seed)
    world = build_world(TargetScene(SceneConfig(name="targets", seed=seed), boards), rig)
    out = []
    with StereoRenderer(world, rig, depth=True, gray=True) as renderer:
        for T_w_b in poses:
            fr = renderer.render(T_w_b)
            out.append((fr.images[0], fr.images[1], fr.depth[0]))
    return out


def _add_noise(img: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    return add_image_noise(img, sigma, rng)


def match_board(left, right, depth, range_m: float, f_px: float, baseline_m: float, matcher: str,
                max_disparity_px: float, cx_offset_px: float = 0.0) -> tuple:
    """Match one board frame -> ``(d_meas (N,), d_true (N,), Z_true (N,))`` for matched pixels
    (matcher status ok); ``d_true = f b / Z`` from ``depth`` at the (integer) left pixel.

    ``cx_offset_px``: the right camera's principal point is ``cx + cx_offset_px``, so the image
    disparity is ``u0 - u1 = f b / Z - cx_offset_px``; the returned ``d_meas`` is the calibrated
    disparity ``u0 - u1 + cx_offset_px``."""
    if matcher == "klt":
        mask = board_mask(depth, range_m, margin_px=12)
        p, d, ok = klt_disparities(left, right, mask)
    elif matcher == "sgbm":
        mask = board_mask(depth, range_m, margin_px=5)
        p, d, ok = sgbm_disparities(left, right, mask, max_disparity_px)
    else:
        raise SimError(f"validate range: unknown matcher {matcher!r}; valid: {', '.join(MATCHERS)}")
    uv = np.rint(p[ok]).astype(int)
    Z = depth[uv[:, 1], uv[:, 0]].astype(np.float64)
    return d[ok] + cx_offset_px, disparity_from_depth(Z, f_px, baseline_m), Z


# ----------------------------------------------------------------------------- the check
def _validate_args(baselines, ranges, matchers, image_noise, min_samples, tolerance, outlier_px) -> None:
    bad = [m for m in matchers if m not in MATCHERS]
    if bad or not matchers:
        raise SimError(f"validate range: unknown matcher(s) {bad or list(matchers)}; valid: {', '.join(MATCHERS)}")
    for name, vals in (("baselines", baselines), ("ranges", ranges)):
        v = np.asarray(vals, float)
        if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v <= 0):
            raise SimError(f"validate range: {name} must be positive finite metres, got {tuple(vals)!r}")
    if not (np.isfinite(image_noise) and image_noise >= 0):
        raise SimError(f"validate range: image_noise must be >= 0 grey levels, got {image_noise!r}")
    if min_samples < 1 or not 0 < tolerance < 10 or not outlier_px > 0:
        raise SimError(f"validate range: need min_samples >= 1, 0 < tolerance, outlier_px > 0; "
                       f"got {min_samples!r}, {tolerance!r}, {outlier_px!r}")


def _bins_for(matches, ranges, b: float, f: float, matcher: str, outlier_px: float) -> tuple:
    """Per-range inlier errors -> (MatcherFit, [BinResult])."""
    e_all, per_bin = [], []
    n_tot = n_out = 0
    for (d, d_true, Z), r in zip(matches, ranges):
        inl = (np.abs(d - d_true) <= outlier_px) & (d > 0)
        n_tot, n_out = n_tot + d.size, n_out + int((~inl).sum())
        e = d[inl] - d_true[inl]
        e_all.append(e)
        per_bin.append((r, float(np.median(d_true)) if d_true.size else f * b / r, e,
                        f * b / d[inl] - Z[inl], int((~inl).sum())))
    e_pool = np.concatenate(e_all) if e_all else np.zeros(0)
    sigma_p = robust_scale(e_pool)
    fit = MatcherFit(b, matcher, sigma_p, int(e_pool.size), n_out / n_tot if n_tot else float("nan"))
    bins = [BinResult(b, matcher, float(r), d0, int(e.size), nout, robust_scale(e),
                      float(np.median(e)) if e.size else float("nan"),
                      float(range_sigma(r, b, f, sigma_p)), robust_scale(dZ))
            for r, d0, e, dZ, nout in per_bin]
    return fit, bins


def measure_range_errors(baselines=(0.063, 0.12, 0.27, 0.5), ranges=(2, 3, 5, 7, 10, 15, 20, 25, 30),
                         matchers=("klt", "sgbm"), image_noise: float = 1.0, seed: int = 0,
                         rig: str = "stereo27", min_samples: int = 30, tolerance: float = 0.2,
                         outlier_px: float = 3.0, phases: int = 16,
                         half_angles_deg=(10.0, 7.0)) -> RangeValidation:
    """Render, match and compare measured with predicted (eq. 7) range errors; see module docstring.

    ``image_noise``: std (grey levels) of i.i.d. Gaussian noise added to each 8-bit grey image,
    drawn from ``sim.rng.stream(seed, "image_noise")`` in the order baseline, phase, range, left, right.
    ``phases``: each range is rendered ``phases`` times with the right camera's ``cx`` offset by
    ``j / phases + j / (16 phases)`` px (j = 0..phases-1), so a bin samples sub-pixel disparity
    phases uniformly at an unchanged range (disparity is corrected by the offset, as a calibrated
    matcher would); the extra ``j / (16 phases)`` interleaves SGBM's 1/16 px output lattices so the
    median-based scales are not stuck on one lattice value.
    """
    matchers = tuple(matchers)
    _validate_args(baselines, ranges, matchers, float(image_noise), int(min_samples), float(tolerance), outlier_px)
    if int(phases) < 1:
        raise SimError(f"validate range: phases must be >= 1, got {phases!r}")
    base = get_rig(rig)
    rng = stream(seed, "image_noise")
    fits, bins = [], []
    for b in map(float, baselines):
        rig_b = apply_overrides(base, [f"baseline={b!r}"])
        f = float(rig_b.cameras[0].fx)
        per_m = {m: [[] for _ in ranges] for m in matchers}
        for j in range(int(phases)):
            dcx = j / int(phases) + j / (16.0 * int(phases))   # dithers SGBM's 1/16 px lattice too
            rig_bj = apply_overrides(rig_b, [f"cam1.cx={rig_b.cameras[1].cx + dcx!r}"])
            frames = render_board_frames(rig_bj, ranges, seed=seed, half_angles_deg=half_angles_deg)
            noisy = [(_add_noise(L, image_noise, rng), _add_noise(R, image_noise, rng), Z) for L, R, Z in frames]
            for m in matchers:
                for k, ((L, R, Z), r) in enumerate(zip(noisy, ranges)):
                    per_m[m][k].append(match_board(L, R, Z, float(r), f, b, m, f * b / min(ranges), dcx))
        for m in matchers:
            matches = [tuple(np.concatenate(x) for x in zip(*runs)) for runs in per_m[m]]
            fit, bb = _bins_for(matches, ranges, b, f, m, outlier_px)
            fits.append(fit)
            bins.extend(bb)
    return RangeValidation(base.name, float(base.cameras[0].fx), float(image_noise), int(seed), int(min_samples),
                           float(tolerance), tuple(fits), tuple(bins))


def plot_range_validation(res: RangeValidation, path) -> None:
    """One panel per baseline: eq. 7 line (per matcher's sigma_p) vs measured points, log y."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    baselines = sorted({f.baseline_m for f in res.fits})
    fig, axes = plt.subplots(1, len(baselines), figsize=(4.2 * len(baselines), 3.8), squeeze=False)
    colors = {"klt": "tab:blue", "sgbm": "tab:orange"}
    for ax, b in zip(axes[0], baselines):
        for fit in [f for f in res.fits if f.baseline_m == b]:
            bb = res.bins_for(b, fit.matcher)
            r = np.array([x.range_m for x in bb])
            rr = np.linspace(r.min(), r.max(), 100)
            c = colors.get(fit.matcher)
            ax.plot(rr, range_sigma(rr, b, res.f_px, fit.sigma_p_px), "-", color=c,
                    label=f"eq. 7, {fit.matcher} sigma_p={fit.sigma_p_px:.3f}")
            ok = np.array([x.n >= res.min_samples for x in bb])
            meas = np.array([x.measured_sigma_r_m for x in bb])
            ax.plot(r[ok], meas[ok], "o", color=c, label=f"measured {fit.matcher}")
            ax.plot(r[~ok], meas[~ok], "x", color=c)
        ax.set_yscale("log")
        ax.set_xlabel("range (m)")
        ax.set_title(f"b = {b:.3f} m")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("1-sigma range error (m)")
    fig.suptitle(f"{res.rig}: f = {res.f_px:.0f} px, image noise {res.image_noise:g}")
    os.makedirs(os.path.dirname(os.path.abspath(str(path))), exist_ok=True)
    fig.savefig(str(path), dpi=100, bbox_inches="tight")
    plt.close(fig)
