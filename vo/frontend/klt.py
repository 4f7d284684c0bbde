"""KLT front-end of seed 003 (Huang & Tan): grid cells, one Shi-Tomasi corner per empty cell, pyramidal
Lucas-Kanade with a forward-backward check, calibrated epipolar check, empty-cell keyframe criterion.

Pyramid levels: seed 003 says "pyramid level 4"; OpenCV's ``maxLevel`` is the index of the coarsest level
(0 = no pyramid), so 4 levels (full resolution + 3 halvings) is ``maxLevel = levels - 1 = 3``.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

import cv2
import numpy as np

from vo.errors import VoError
from vo.frontend.grid import Grid
from vo.frontend.klt_pyramids import LkPyramids, lk_raw
from vo.frontend.lk_invariant import lk_illumination_invariant
from vo.frontend.lk_normalized import PyramidCache, lk_pyramids, mirrored_start, normalized_pyramid
from vo.frontend.epipolar_offset import offset_epipolar_mask
from vo.frontend.patch_check import zncc_mask
from vo.frontend.stereo import epipolar_mask


@dataclass(frozen=True)
class KltConfig:
    """Parameters (defaults: seed 003 Table 1 / sections 4-5).

    ``cell`` grid cell size (px); ``max_empty_fraction`` keyframe when empty cells / cells exceeds it
    (seed 003 Table 2 best: 0.42); ``min_inliers`` keyframe when PnP inliers fall below it (100);
    ``win`` LK window (21x21); ``levels`` pyramid levels incl. full resolution (4 -> OpenCV maxLevel 3);
    ``fb_threshold_px`` forward-backward tolerance (1 px); ``epipolar_threshold_px`` stereo epipolar
    tolerance; ``quality_level``, ``min_distance``, ``block_size`` Shi-Tomasi parameters;
    ``min_eigenvalue`` absolute floor on the Shi-Tomasi score (rejects corners of blank cells);
    ``illumination_invariant`` use :func:`lk_illumination_invariant` instead of OpenCV's LK;
    ``normalize_box`` (default 2): OpenCV's LK runs on local-mean-normalised pyramids
    (:mod:`vo.frontend.lk_normalized`, seed 003's intensity-invariant residual of section 5.2), each level
    divided by its mean over ``normalize_box`` x ``win`` pixels; 0 = the raw images (brightness constancy).
    Two windows rather than one: on the ideal-camera indoor route the 1-window mean cost stereo matches at
    large disparities (the normalised window then holds less of the coarse structure), see docs/estimators.md;
    ``raw_fallback`` (with ``normalize_box``): the points the normalised LK loses are tried again by OpenCV's
    LK on the raw images (forward-backward checked alike), so a view where brightness constancy holds and the
    normalised windows lack coarse structure (fast turns, large disparities) keeps the matches it had;
    ``stereo_win`` LK window of the left -> right stereo match in :func:`stereo_klt` only (0 = ``win``;
    temporal tracking always uses ``win``). Seed 003 uses one 21x21 window for both.
    ``offset_min_matches``, ``offset_max_px``: the stereo epipolar gate is ``epipolar_threshold_px`` around
    the frame's own robust row offset (:mod:`vo.frontend.epipolar_offset`: the median signed epipolar
    distance of the forward-backward-kept matches, used when there are at least ``offset_min_matches`` and
    it is at most ``offset_max_px``; not in seed 003); ``offset_max_px = 0`` gives seed 003's gate around
    the calibrated line.
    ``stereo_prior`` (``klt-pnp``'s new landmarks; off by default): the new corners the stereo LK loses from
    zero disparity are searched again from the disparity of their nearest landmarks
    (:mod:`vo.frontend.stereo_prior`; not in seed 003; measured in docs/estimators.md: better on the seed it
    was developed on, worse on a held-out one).
    ``edge_win``, ``edge_win_h``, ``edge_threshold_px`` the depth-edge test of new stereo landmarks
    (:mod:`vo.frontend.depth_edge`; not in seed 003): LK window (width x height, px) of its disparity samples
    and the largest one-sided second difference of the disparity (px) a landmark may show; 0 (the default)
    turns it off (experimental: at 2 px it removes most big-step edge landmarks but did not lower the drift
    (docs/estimators.md, "Depth-edge test")).
    ``min_zncc`` (not in seed 003): every LK match of :func:`track_fb` (temporal and stereo) is kept only when
    the ZNCC of its two ``win`` x ``win`` windows on the raw images reaches it
    (:mod:`vo.frontend.patch_check`; default 0.5: window texture at least as strong as the image noise); -1
    turns the check off. ``zncc_affine``: a match below the gate stays when its window's affine fit correlates
    (default False: measured better on the real turn, worse on a held-out `indoor-realistic` seed;
    :mod:`vo.frontend.patch_check`).
    """

    cell: int = 32
    max_empty_fraction: float = 0.42
    min_inliers: int = 100
    win: int = 21
    levels: int = 4
    fb_threshold_px: float = 1.0
    epipolar_threshold_px: float = 1.0
    quality_level: float = 0.01
    min_distance: float = 5.0
    block_size: int = 3
    min_eigenvalue: float = 1e-4
    lk_iters: int = 30
    lk_eps: float = 0.01
    illumination_invariant: bool = False
    stereo_win: int = 0
    normalize_box: float = 2.0
    raw_fallback: bool = True
    offset_min_matches: int = 10
    offset_max_px: float = 3.0
    stereo_prior: bool = False
    edge_win: int = 11
    edge_win_h: int = 11
    edge_threshold_px: float = 0.0
    min_zncc: float = 0.5
    zncc_affine: bool = False

    def __post_init__(self):
        checks = {
            "cell": self.cell >= 8, "win": self.win >= 3 and self.win % 2 == 1, "levels": self.levels >= 1,
            "max_empty_fraction": 0.0 <= self.max_empty_fraction <= 1.0, "min_inliers": self.min_inliers >= 0,
            "fb_threshold_px": self.fb_threshold_px > 0, "epipolar_threshold_px": self.epipolar_threshold_px > 0,
            "quality_level": 0 < self.quality_level < 1, "min_distance": self.min_distance >= 0,
            "block_size": self.block_size >= 3 and self.block_size % 2 == 1, "min_eigenvalue": self.min_eigenvalue >= 0,
            "lk_iters": self.lk_iters >= 1, "lk_eps": self.lk_eps > 0,
            "stereo_win": self.stereo_win == 0 or (self.stereo_win >= 3 and self.stereo_win % 2 == 1),
            "normalize_box": self.normalize_box == 0 or self.normalize_box >= 1,
            "edge_win": self.edge_win >= 3 and self.edge_win % 2 == 1,
            "edge_win_h": self.edge_win_h >= 3 and self.edge_win_h % 2 == 1,
            "edge_threshold_px": self.edge_threshold_px >= 0,
            "offset_min_matches": self.offset_min_matches >= 1, "offset_max_px": self.offset_max_px >= 0,
            "min_zncc": -1.0 <= self.min_zncc <= 1.0,
        }
        checks.update({f.name: isinstance(getattr(self, f.name), (bool, np.bool_))
                       for f in fields(self) if f.type in (bool, "bool")})
        for name, good in checks.items():
            if not good:
                raise VoError(f"KltConfig.{name}: invalid value {getattr(self, name)!r} "
                              "(cell>=8, odd win>=3, stereo_win 0 or odd >=3, odd edge_win>=3, levels>=1, "
                              "normalize_box 0 or >= 1, 0<=max_empty_fraction<=1, thresholds > 0, "
                              "edge_threshold_px >= 0, -1 <= min_zncc <= 1, switches true or false)")

    @classmethod
    def from_option(cls, value, where: str = "klt_config") -> "KltConfig":
        """An estimator's ``klt_config`` option -> :class:`KltConfig`: ``None`` (the defaults), a
        :class:`KltConfig`, or a mapping of field names (``--opt 'klt_config={win: 11}'``)."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        if not isinstance(value, dict):
            raise VoError(f"{where}: {value!r}; expected a mapping of KltConfig fields, e.g. {{win: 11}}")
        names = [f.name for f in fields(cls)]
        bad = sorted(set(value) - set(names))
        if bad:
            raise VoError(f"{where}: unknown field(s) {bad}; valid: {', '.join(names)}")
        return cls(**value)

    @property
    def box(self) -> int:
        """Odd side (px) of the local-mean window of the normalised pyramids (0 = no normalisation)."""
        return int(round(self.normalize_box * self.win)) | 1 if self.normalize_box else 0

    def pyramid(self, img: np.ndarray) -> list | None:
        """The normalised pyramid of ``img`` (:func:`normalized_pyramid`), or None without normalisation."""
        return normalized_pyramid(img, self.levels, self.box) if self.box else None

    def pyramid_cache(self) -> PyramidCache | None:
        """A :class:`PyramidCache` of this configuration's pyramids (None without normalisation)."""
        return PyramidCache(self.levels, self.box) if self.box else None

    @property
    def max_level(self) -> int:
        """OpenCV ``maxLevel`` (0-based index of the coarsest level)."""
        return self.levels - 1

    @property
    def reach_px(self) -> float:
        """The largest displacement (px) a zero-flow pyramidal LK can find: half the window at the coarsest level,
        ``2^max_level x win / 2`` (84 px for 4 levels and 21 px)."""
        return float(2 ** self.max_level * self.win / 2)


def is_keyframe(empty_fraction: float, n_inliers: int, config: KltConfig = KltConfig()) -> bool:
    """Seed 003's criterion: the next frame is a keyframe when the empty-cell fraction exceeds
    ``max_empty_fraction`` or the PnP inliers are fewer than ``min_inliers``."""
    return empty_fraction > config.max_empty_fraction or n_inliers < config.min_inliers


def detect_in_empty_cells(img: np.ndarray, grid: Grid, existing_pts: np.ndarray,
                          config: KltConfig = KltConfig(), peaks_only: bool = True) -> np.ndarray:
    """One best Shi-Tomasi corner per empty non-border cell -> (M,2) float64 integer pixels, in cell order.

    One ``cv2.cornerMinEigenVal`` over the whole image and a per-cell maximum (:meth:`Grid.best_in_cells`);
    a corner needs a score >= ``min_eigenvalue`` and > ``quality_level`` x the cell's maximum.
    ``peaks_only`` (seed 003's ``goodFeaturesToTrack`` rule, the same corners as one call per cell): only
    3x3 local maxima of the score compete, so a cell whose maximum sits on its edge below a higher
    neighbour in the next cell gets its best interior peak. ``peaks_only=False`` (the ``rop`` front-end,
    :mod:`vo.rop.tracks`) takes the cell's maximum wherever it is; ~8 % of the cells then get another
    corner, and rop's benchmarked drift depends on it (docs/estimators.md).
    """
    cells = grid.detection_cells(existing_pts)
    if len(cells) == 0:
        return np.zeros((0, 2))
    eig = cv2.cornerMinEigenVal(img, config.block_size)
    score = np.where(eig >= cv2.dilate(eig, None), eig, -np.inf) if peaks_only else eig
    best, uv = grid.best_in_cells(score, last=peaks_only)
    keep = best[cells] >= config.min_eigenvalue
    if peaks_only:
        keep &= best[cells] > config.quality_level * grid.best_in_cells(eig)[0][cells]
    return uv[cells[keep]]


def lk(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, config: KltConfig = KltConfig(),
       pyramids: tuple | None = None, guess: np.ndarray | None = None) -> tuple:
    """One-directional pyramidal LK -> ``(p1 (N,2), ok (N,))``: the illumination-invariant one when
    ``config.illumination_invariant``, else OpenCV's on the normalised pyramids (``pyramids``, the two
    images' :meth:`KltConfig.pyramid`, built here when None) or, with ``normalize_box = 0``, on the raw images
    (``pyramids``: their raw pyramids, :meth:`LkPyramids.raw`, or None).
    ``guess`` (N,2): start points in ``img1`` (OpenCV's LK only; default zero flow)."""
    p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
    if p0.shape[0] == 0:
        return np.zeros((0, 2)), np.zeros(0, bool)
    if config.illumination_invariant:
        return lk_illumination_invariant(img0, img1, p0, config.win, config.levels, config.lk_iters, config.lk_eps)
    if config.box:
        pyr0, pyr1 = pyramids if pyramids is not None else (config.pyramid(img0), config.pyramid(img1))
        return lk_pyramids(pyr0, pyr1, p0, config.win, config.lk_iters, config.lk_eps, guess)
    p1, st = lk_raw(img0, img1, p0, config.win, config.max_level, config.lk_iters, config.lk_eps, guess, pyramids)
    p1 = p1.reshape(-1, 2).astype(np.float64)
    h, w = img1.shape[:2]
    ok = st.reshape(-1).astype(bool) & np.all(np.isfinite(p1), axis=1)
    ok &= (p1[:, 0] >= 0) & (p1[:, 1] >= 0) & (p1[:, 0] <= w - 1) & (p1[:, 1] <= h - 1)
    return p1, ok


def track_fb(img0: np.ndarray, img1: np.ndarray, p0: np.ndarray, config: KltConfig = KltConfig(),
             pyramid=None, guess: np.ndarray | None = None, mirror: bool = False) -> tuple:
    """LK ``img0 -> img1`` then back; keep points whose round trip ends < ``fb_threshold_px`` from the start
    and whose windows correlate (ZNCC >= ``min_zncc``, :mod:`vo.frontend.patch_check`).
    ``pyramid`` (image -> normalised pyramid, e.g. a :class:`PyramidCache`) defaults to ``config.pyramid``; an
    :class:`LkPyramids` also gives the raw pyramids of the raw-image LK (built once per image);
    ``guess`` (N,2) start points of the forward LK in ``img1`` (default: zero flow). The backward LK starts at
    ``p0`` (a search known to end there, e.g. a stereo match from the previous disparity) or, with ``mirror``,
    at the guess (a motion prediction) mirrored through the forward result, ``p1 - (guess - p0)``: as far from
    ``p0`` as the forward result lies from its guess, so the round trip stays a test of the match.

    Returns ``(p1 (N,2) float64, ok (N,) bool)``.
    """
    p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
    if p0.shape[0] == 0:
        return np.zeros((0, 2)), np.zeros(0, bool)
    pyramid = pyramid or config.pyramid
    pyr = (pyramid(img0), pyramid(img1)) if config.box and not config.illumination_invariant else None
    if not config.box and not config.illumination_invariant and isinstance(pyramid, LkPyramids):
        pyr = tuple(pyramid.raw(im, config.win, config.max_level) for im in (img0, img1))
    if config.illumination_invariant:
        guess = None
    p1, ok_f = lk(img0, img1, p0, config, pyr, guess)
    back = np.where(ok_f[:, None], p1, p0)
    start = None                                  # the backward LK's start points (docstring)
    if guess is not None:
        start = mirrored_start(back, guess, p0) if mirror else p0
    p0b, ok_b = lk(img1, img0, back, config, None if pyr is None else pyr[::-1], start)
    ok = ok_f & ok_b & (np.linalg.norm(p0b - p0, axis=1) < config.fb_threshold_px)
    if config.box and pyr is not None and config.raw_fallback and not ok.all():
        lost = np.flatnonzero(~ok)
        p1[lost], ok[lost] = track_fb(img0, img1, p0[lost], replace(config, normalize_box=0, min_zncc=-1.0),
                                      pyramid, None if guess is None else np.asarray(guess)[lost], mirror)
    return p1, zncc_mask(img0, img1, p0, p1, ok, config.win, config.min_zncc, config.zncc_affine)


def stereo_klt(left: np.ndarray, right: np.ndarray, p_left: np.ndarray, rig,
               config: KltConfig = KltConfig(), pyramid=None, prior: np.ndarray | None = None) -> tuple:
    """Left -> right LK with forward-backward and calibrated epipolar checks -> ``(p_right, ok)``.

    The LK window (both directions) is ``config.stereo_win`` when set, else ``config.win`` (a ``pyramid``
    cache is then not used: its box follows ``win``). ``prior`` (N,2) right-image start points
    (:mod:`vo.frontend.stereo_prior`): the points the search from zero disparity loses are searched again
    from there (those whose first match fails the forward-backward or the epipolar check), with the same checks."""
    if config.stereo_win:
        config, pyramid = replace(config, win=config.stereo_win), None
    p_left = np.asarray(p_left, np.float64).reshape(-1, 2)
    p_right, ok = track_fb(left, right, p_left, config, pyramid)
    if prior is not None:
        gated = ok.copy()
        gated[ok] &= stereo_gate(rig, p_left[ok], p_right[ok], config)
        lost = np.flatnonzero(~gated)
        p2, ok2 = track_fb(left, right, p_left[lost], config, pyramid, np.asarray(prior)[lost])
        p_right[lost[ok2]], ok[lost[ok2]] = p2[ok2], True
    if ok.any():
        ok[ok] &= stereo_gate(rig, p_left[ok], p_right[ok], config)
    return p_right, ok


def stereo_gate(rig, p_left: np.ndarray, p_right: np.ndarray, config: KltConfig = KltConfig()) -> np.ndarray:
    """(N,) bool epipolar gate of stereo matches (raw pixels): ``config.epipolar_threshold_px`` around
    the matches' own row offset (:func:`offset_epipolar_mask`), or around the calibrated line when
    ``config.offset_max_px`` is 0."""
    if not config.offset_max_px:
        return epipolar_mask(rig, p_left, p_right, config.epipolar_threshold_px)
    return offset_epipolar_mask(rig, p_left, p_right, config.epipolar_threshold_px, config.offset_min_matches,
                                config.offset_max_px)[0]


class TrackIds:
    """Source of persistent track identities: ``take(n)`` -> (n,) int64 ids, never reused."""

    def __init__(self):
        self._next = 0

    def take(self, n: int) -> np.ndarray:
        ids = np.arange(self._next, self._next + n, dtype=np.int64)
        self._next += n
        return ids


class KltTracker:
    """Frame-to-frame KLT tracks with persistent integer ids on the left image.

    ``pts`` (N,2) current pixel positions, ``ids`` (N,) int64 track ids (never reused).
    """

    def __init__(self, width: int, height: int, config: KltConfig = KltConfig()):
        self.config = config
        self.grid = Grid(width, height, config.cell)
        self.pts = np.zeros((0, 2))
        self.ids = np.zeros(0, np.int64)
        self.image = None
        self._ids = TrackIds()
        self.pyramid = LkPyramids(config.levels, config.box) if config.box else None   # of the last images

    def track(self, img: np.ndarray, guess: np.ndarray | None = None) -> np.ndarray:
        """Track all points into ``img`` (forward-backward checked); drop failures. Returns the
        (N_prev,) bool survival mask over the previous points. ``guess`` (N,2): predicted positions in ``img``,
        the forward LK's start points (the backward's mirrored: :func:`track_fb`); default zero flow."""
        if self.image is None or len(self.pts) == 0:
            self.image = img
            ok = np.zeros(len(self.pts), bool)
            self.pts, self.ids = self.pts[ok], self.ids[ok]
            return ok
        p1, ok = track_fb(self.image, img, self.pts, self.config, self.pyramid, guess, mirror=True)
        self.pts, self.ids, self.image = p1[ok], self.ids[ok], img
        return ok

    def detect(self, img: np.ndarray) -> np.ndarray:
        """Add one corner per empty non-border cell of ``img``; returns the new ids."""
        new = detect_in_empty_cells(img, self.grid, self.pts, self.config)
        ids = self._ids.take(len(new))
        self.pts = np.vstack([self.pts, new])
        self.ids = np.concatenate([self.ids, ids])
        self.image = img
        return ids

    def append(self, pts: np.ndarray, ids: np.ndarray) -> None:
        """Add existing tracks (pixels ``pts`` (M,2), ids ``ids`` (M,) taken from this tracker earlier) after the
        current ones, e.g. tracks set aside by :meth:`keep` while :meth:`detect` filled the cells."""
        self.pts = np.vstack([self.pts, np.asarray(pts, np.float64).reshape(-1, 2)])
        self.ids = np.concatenate([self.ids, np.asarray(ids, np.int64)])

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the tracks where ``mask`` (N,) is True."""
        self.pts, self.ids = self.pts[mask], self.ids[mask]

    def reset(self) -> None:
        """Drop every track (ids keep increasing)."""
        self.keep(np.zeros(len(self.pts), bool))

    @property
    def empty_fraction(self) -> float:
        return self.grid.empty_fraction(self.pts)
