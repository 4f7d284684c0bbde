"""Online estimate of a stereo disparity offset (a calibration error of the right camera's principal point).

A rectified stereo rig measures depth ``z = f b / d``. When the written calibration puts the right camera's
principal point ``delta`` px off the images' (the real KITTI excerpt: 1.2-1.4 px, docs/estimators.md), every
disparity is ``delta`` px short and every depth long by ``delta / d``: far landmarks much more than near ones,
so a PnP step on them is long (the excerpt: 5-13 %) and no choice of landmarks removes the bias.

The offset is observable from the tracks alone, independently of the (biased) scale of the motion: structure
from motion fixes the landmarks' depths up to one scale, and ``f b / z = D + delta`` with raw disparities ``D``
over a range of depths separates that scale from ``delta`` (a scale error is the same factor at every depth, the
offset is not). :class:`DisparityOffset` adjusts, once per birth keyframe and when the camera has travelled
``min_travel_baselines`` baselines from it, the poses of the frames since then and ``delta`` together on the
reprojection error of that keyframe's landmarks, each placed at ``f b / (D + delta)`` along its birth ray
(``scipy.optimize.least_squares``, LM, then again without the observations beyond 2 px), and averages the
keyframes' estimates with their variances.
It reports an offset (:attr:`DisparityOffset.delta_px`) only when the average is significantly (``significance``
standard errors of the keyframes' spread) beyond what matters for depth: ``|delta| - significance * se >
min_depth_error * d_med``, i.e. the relative depth (and step-length) error ``|delta| / d_med`` it makes at the
tracked landmarks' median raw disparity ``d_med`` is beyond ``min_depth_error`` by more than its uncertainty
(an estimate near that floor is not switched on and off as it wanders); otherwise 0, and the estimator using
it is unchanged. Measured (docs/estimators.md, "Coasting on the median step, and when the disparity offset is
applied"): on consistent calibrations the estimate (the stereo matcher's own sub-pixel bias and the model's
residual errors) is 0.15-0.51 % of the median disparity; on the seeded 0.44-0.49 px error of the ``realistic``
campus rig 2.3-2.6 % before it is applied (3.6-5.7 % after), on the real KITTI turn about 11 %: the default 1 %
lies about a factor 2 from each side. A pixel floor, ``tolerance_px``, is 0 by default: a fixed pixel tolerance
is too much for a far scene (small disparities, where an offset matters most) and too little for a near one.
The tracks it is fitted on are ``klt-pnp``'s PnP inliers and the outliers near the pose (the inliers alone are
a selection that pulls the estimate short of the offset: :mod:`vo.estimators.track_gate`); the fits on the pose
tracks (the inliers) alone must pass the same test and agree with it (same sign, at least ``pose_share`` of its
size), since in traffic the outliers near the pose include actors moving with the camera, which bias the estimate
(the selection pulls the pose tracks' mean 0-15 % short of the offset; actors pull the mean of all by multiples).
Depths are then corrected
along each landmark's birth ray: ``z' = f b / (f b / z + delta)``
(exact on a rectified rig; on an unrectified one the offset of the equivalent rectified pair).

Not in seed 003 (whose KITTI calibration is consistent); it repairs a calibration error, as an online
stereo self-calibration of the principal-point offset, and reads nothing but the tracks and poses.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

from rigs.geometry import inv_T
from rigs.typed_config import check_fields, from_mapping, knob
from vo.errors import EstimatorError


@dataclass(frozen=True)
class OffsetConfig:
    """``enabled`` estimate and apply the offset; ``min_travel_baselines`` a birth keyframe's landmarks are
    used once the camera is that many baselines from it (parallax); ``min_landmarks`` landmarks of one
    keyframe needed for its fit; ``min_keyframes`` fits before an offset is reported; ``min_depth_error``
    smallest relative depth error ``|delta| / d_med`` at the tracked landmarks' median raw disparity for which
    an offset is applied (module docstring); ``tolerance_px`` smallest offset applied (px; 0: none);
    ``significance`` standard errors by which the mean must exceed the larger of the two; ``replay_frames``
    frames since the (re)initialisation that ``klt-pnp`` re-chains when the offset is first applied
    (:mod:`vo.estimators.offset_replay`; 0: none, the frames before keep their long steps), again whenever the
    applied offset has moved by more than ``replay_step_px`` since; ``track_gate_px`` PnP outliers within it of
    the fitted pose stay tracks for the estimate to see, out of every later PnP (:mod:`vo.estimators.track_gate`;
    0: all dropped, as in seed 003); ``pose_share`` the smallest share of the applied mean that the pose tracks'
    mean must reach, with the same sign (:meth:`DisparityOffset._update`)."""

    enabled: bool = True
    min_travel_baselines: float = knob(6.0, gt=0)
    min_landmarks: int = knob(15, ge=4)
    min_keyframes: int = knob(3, ge=1)
    tolerance_px: float = knob(0.0, ge=0)
    min_depth_error: float = knob(0.01, ge=0)
    significance: float = knob(3.0, ge=0)
    track_gate_px: float = knob(4.0, ge=0)
    replay_frames: int = knob(200, ge=0)
    replay_step_px: float = knob(0.1, ge=0)
    pose_share: float = knob(0.5, ge=0, le=1)

    def __post_init__(self):
        check_fields(self, EstimatorError, "disparity_offset.")

    @classmethod
    def from_option(cls, value, where: str = "disparity_offset") -> "OffsetConfig":
        if isinstance(value, cls):
            return value
        return from_mapping(cls, value, EstimatorError, where)


# Landmarks a later frame must see to enter a keyframe's adjustment: with fewer, its pose (6 parameters) is
# undetermined, the normal matrix is singular, and whether the fit then fails or returns an arbitrary offset
# follows the last bits of the arithmetic (which differ with the arrays' memory alignment from process to
# process: on the real KITTI turn one keyframe's fit had a frame with 1 landmark, J of rank 21 of 25, and two
# heap layouts gave two trajectories).
MIN_FRAME_LANDMARKS = 3


class DisparityOffset:
    """The online offset estimate of one estimator run (module docstring). Landmarks are registered at birth
    (:meth:`add`), their tracks fed each frame (:meth:`observe`); :attr:`delta_px` is the offset to apply (0
    until significant) and :meth:`correct` moves a landmark along its birth ray to the corrected depth."""

    max_frames = 4               # frames of one keyframe's adjustment (its cost grows as their square)

    def __init__(self, config: OffsetConfig, f_px: float, baseline_m: float):
        self.config, self.f, self.fb, self.baseline_m = config, f_px, f_px * baseline_m, baseline_m
        self.births: dict = {}       # id -> (birth centre (3,), raw depth)
        self.keyframes: dict = {}    # birth frame -> (centre (3,), ids (N,), rays (N,3), raw depths (N,)) until fitted
        self.history: list = []      # (frame, T_o_c0 (4,4), ids (N,), normalised points (N,2), pose mask (N,) | None)
        self.fits: list = []         # (delta, variance) per fitted keyframe
        self.pose_fits: list = []    # the same fits on the observations of pose-defining tracks only
        self.delta_px = 0.0
        self.se_px = float("nan")    # standard error of the average (nan until min_keyframes fits)
        self._frame = 0

    def add(self, ids, c_b: np.ndarray, dir_o: np.ndarray, z_raw: np.ndarray) -> None:
        """Landmarks ``ids`` (N,) born on the current frame at camera centre ``c_b`` (3,), left rays ``dir_o``
        (N,3) (unit depth in the birth camera) and raw stereo depths ``z_raw`` (N,)."""
        if not self.config.enabled or len(ids) == 0:
            return
        c_b = np.asarray(c_b, float).copy()
        ids = np.asarray(ids, np.int64)
        self.keyframes[self._frame] = (c_b, ids, np.asarray(dir_o, float), np.asarray(z_raw, float))
        for i, z in zip(ids, z_raw):
            self.births[int(i)] = (c_b, float(z))

    def forget(self, alive_ids) -> None:
        """Drop landmarks no longer tracked from the depth corrections."""
        alive = {int(i) for i in alive_ids}
        self.births = {i: b for i, b in self.births.items() if i in alive}

    def observe(self, ids, x_n: np.ndarray, T_o_c0: np.ndarray, pose=None) -> None:
        """The current frame: the estimated pose ``T_o_c0`` (4,4) and the normalised points ``x_n`` (N,2) of the
        tracked landmarks ``ids`` (N,), of which ``pose`` (N,) bool (default all) define the pose (the others are
        kept for this estimate only, :mod:`vo.estimators.track_gate`). Fits the keyframes the camera is now far
        enough from (:meth:`fit_keyframe`) on all of them, and again on the pose tracks alone where they differ,
        and updates :attr:`delta_px` (:meth:`_update`). Both fits are made at once: made only when the decision
        reads them, the pose-track fits would keep every keyframe's observations until then, on a consistent rig
        for the whole route."""
        cfg = self.config
        if not cfg.enabled:
            return
        self._frame += 1
        self.history.append((self._frame, np.asarray(T_o_c0, float).copy(), np.asarray(ids, np.int64).copy(),
                             np.asarray(x_n, float).copy(), None if pose is None else np.asarray(pose, bool).copy()))
        c_k = T_o_c0[:3, 3]
        due = [k for k, g in self.keyframes.items()
               if np.linalg.norm(c_k - g[0]) >= cfg.min_travel_baselines * self.baseline_m]
        for k in due:
            g = self.keyframes.pop(k)      # the birth frame itself (pose at c_b) adds nothing
            later = [h for h in self.history if h[0] > k and np.any(h[1][:3, 3] != g[0])]
            n_pick = min(len(later), self.max_frames)
            pick = np.unique(np.round(np.linspace(0, len(later) - 1, n_pick)).astype(int))
            frames = [later[j] for j in pick]
            fit = self.fit_keyframe(*g, [h[:4] for h in frames]) if later else None
            if any(h[4] is not None and not h[4].all() for h in frames):
                fit_pose = self.fit_keyframe(*g, [(k_, T, i[m], x[m]) if m is not None else (k_, T, i, x)
                                                  for k_, T, i, x, m in frames])
            else:
                fit_pose = fit
            if fit is not None:
                self.fits.append(fit)
            if fit_pose is not None:
                self.pose_fits.append(fit_pose)
        oldest = min(self.keyframes, default=self._frame)
        self.history = [h for h in self.history if h[0] > oldest]
        if due:
            self._update()

    def fit_keyframe(self, c_b, ids, dir_b, z_raw, frames) -> tuple | None:
        """One keyframe's landmarks (``ids`` (M,), birth centre ``c_b``, rays ``dir_b`` (M,3), raw depths
        ``z_raw`` (M,)) seen on later ``frames`` ((frame, T_o_c0, ids, x_n) each; :meth:`observe` passes at
        most :attr:`max_frames`, evenly spaced up to the current one, which bounds the cost): the offset and the
        poses of those frames
        adjusted together (reprojection error, LM, refitted without observations beyond 2 px; each landmark at
        depth ``f b / (D + delta)`` along its birth ray) -> ``(delta, variance)`` or None (fewer than
        ``min_landmarks`` landmarks seen after birth, or no solution)."""
        return self._fit_seen(c_b, dir_b, z_raw, _seen(ids, frames))

    def _fit_seen(self, c_b, dir_b, z_raw, seen) -> tuple | None:
        """:meth:`fit_keyframe` on the observations ``seen`` (:func:`_seen`) of its landmarks."""
        if not seen:
            return None
        frames = [fr for fr, _, _ in seen]
        obs_f = np.concatenate([np.full(len(lm), f_i) for f_i, (_, lm, _) in enumerate(seen)])
        obs_l, obs_x = np.concatenate([lm for _, lm, _ in seen]), np.concatenate([x for _, _, x in seen])
        if len(np.unique(obs_l)) < self.config.min_landmarks:
            return None
        d_raw = self.fb / z_raw
        n_f, fb, f = len(frames), self.fb, self.f
        memo: dict = {}          # the model at the last points LM evaluated (its Jacobian comes at one of them)

        def per_frame():
            """Each frame's observations (obs_f is sorted): (slice, landmark indices, their rays)."""
            ends = np.searchsorted(obs_f, np.arange(n_f + 1))
            return [(slice(a, b), obs_l[a:b], dir_b[obs_l[a:b]]) for a, b in zip(ends[:-1], ends[1:])]

        def model(v):
            """Per observation: camera-frame point (K,3), d p_c / d rvec (K,3,3), d p_c / d delta (K,3)."""
            key = v.tobytes()
            if key in memo:
                return memo[key]
            den = np.maximum(d_raw + v[0], 1e-3)
            p_o = c_b[None, :] + dir_b * (fb / den)[:, None]
            p_c, dp_r, dp_d = np.empty((len(obs_f), 3)), np.empty((len(obs_f), 3, 3)), np.empty((len(obs_f), 3))
            for f_i, (m, lm, dirs) in enumerate(frame_obs):
                R, dR = cv2.Rodrigues(v[1 + 6 * f_i:4 + 6 * f_i].reshape(3, 1))
                p = p_o[lm]
                p_c[m] = p @ R.T + v[4 + 6 * f_i:7 + 6 * f_i]
                dp_r[m] = np.einsum("kij,nj->nik", dR.reshape(3, 3, 3), p)
                dp_d[m] = (dirs @ R.T) * (-fb / den[lm] ** 2)[:, None]
            if len(memo) >= 4:
                memo.pop(next(iter(memo)))
            memo[key] = p_c, dp_r, dp_d
            return memo[key]

        def residuals(v):
            p_c = model(v)[0]
            return f * (p_c[:, :2] / np.maximum(p_c[:, 2:3], 1e-6) - obs_x).ravel()

        def jacobian(v):
            p_c, dp_r, dp_d = model(v)
            z = np.maximum(p_c[:, 2], 1e-6)
            P = np.zeros((len(z), 2, 3))                 # d pixel / d p_c
            P[:, 0, 0] = P[:, 1, 1] = f / z
            P[:, :, 2] = -f * p_c[:, :2] / z[:, None] ** 2
            J = np.zeros((len(z), 2, 1 + 6 * n_f))
            J[:, :, 0] = np.einsum("nij,nj->ni", P, dp_d)
            rows = np.arange(len(z))
            for k in range(3):
                J[rows, :, 1 + 6 * obs_f + k] = np.einsum("nij,nj->ni", P, dp_r[:, :, k])
                J[rows, :, 4 + 6 * obs_f + k] = P[:, :, k]
            return J.reshape(2 * len(z), -1)

        v0 = [0.0]
        for _, T_o_c in frames:
            T_c_o = inv_T(T_o_c)
            v0 += [*cv2.Rodrigues(T_c_o[:3, :3])[0].ravel(), *T_c_o[:3, 3]]
        if len(obs_f) * 2 <= len(v0):
            return None
        # MINPACK's LM (its own QR: no threaded BLAS, whose small SVDs cost much CPU on a loaded machine), then
        # again without the observations beyond the PnP inlier gate (2 px) of the first fit.
        frame_obs = per_frame()
        try:
            sol = least_squares(residuals, np.array(v0), jac=jacobian, method="lm", x_scale="jac", max_nfev=50)
            keep = np.linalg.norm(sol.fun.reshape(-1, 2), axis=1) < 2.0
            if 2 * keep.sum() <= len(v0) or len(np.unique(obs_l[keep])) < self.config.min_landmarks \
                    or np.bincount(obs_f[keep], minlength=n_f).min() < MIN_FRAME_LANDMARKS:
                return None
            obs_f, obs_l, obs_x = obs_f[keep], obs_l[keep], obs_x[keep]
            frame_obs = per_frame()
            memo.clear()
            sol = least_squares(residuals, sol.x, jac=jacobian, method="lm", x_scale="jac", max_nfev=50)
            J = sol.jac
            dof = max(J.shape[0] - J.shape[1], 1)
            s2 = max(float(np.sum(sol.fun ** 2)) / dof, 1.0)
            var = s2 * float(np.linalg.inv(J.T @ J)[0, 0])
        except (ValueError, np.linalg.LinAlgError):
            return None
        if not (sol.success and np.isfinite(sol.x[0]) and np.isfinite(var) and var > 0):
            return None
        # To 9 significant digits: the fit's last bits depend on the memory alignment of its arrays (the BLAS
        # and numpy reductions take aligned and unaligned paths), which differs from process to process; the
        # estimate feeds discrete decisions, so those bits would make two runs of one dataset differ.
        return float(f"{sol.x[0]:.9g}"), float(f"{var:.9g}")

    def _update(self) -> None:
        """:attr:`delta_px`: the mean of the fits, applied when it passes :meth:`_significant` and so does the mean
        of the fits on the pose tracks alone. The tracks kept for this estimate only (PnP outliers near the pose)
        remove the inlier gate's selection from the fitted value, but in traffic they include landmarks on
        moving actors, which bias it on a consistent rig; the pose tracks decide whether there is an offset: their
        mean must also be significant and agree with the mean of all (same sign, at least ``pose_share`` of it).
        Where actors pull the mean of all to several times the pose tracks' (the inlier gate's selection alone
        pulls it 0-15 % short: the real KITTI turn 1.46 against 1.31 px), the two measure different things and
        nothing is applied."""
        mean, self.se_px, significant = self._significant(self.fits)
        self.delta_px = mean if significant and self._pose_tracks_agree(mean) else 0.0

    def _pose_tracks_agree(self, mean: float) -> bool:
        """Whether the mean of the fits on the pose tracks alone passes :meth:`_significant` and agrees with
        ``mean`` (px), the mean of all: the same sign and at least ``pose_share`` of its size."""
        pose_mean, _, pose_significant = self._significant(self.pose_fits)
        return pose_significant and pose_mean * mean > 0 and abs(pose_mean) >= self.config.pose_share * abs(mean)

    def _significant(self, fits) -> tuple:
        """``(mean, se, significant)`` of keyframe fits ``[(delta, variance)]``: the weighted mean, its standard
        error from the keyframes' spread (their variances ignore the chain's rotation errors), and whether it is
        beyond what matters for depth (``min_depth_error`` of the median disparity, at least ``tolerance_px``)
        by ``significance`` standard errors (fewer than ``min_keyframes`` fits: ``(0, nan, False)``)."""
        cfg = self.config
        if len(fits) < cfg.min_keyframes:
            return 0.0, float("nan"), False
        d = np.array([f[0] for f in fits])
        w = 1.0 / np.array([max(f[1], 1e-6) for f in fits])
        mean = float(np.sum(w * d) / np.sum(w))
        se = float(np.sqrt(np.sum(w * (d - mean) ** 2) / np.sum(w) / max(len(d) - 1, 1)))
        floor = max(cfg.tolerance_px, cfg.min_depth_error * self.median_disparity_px)
        return mean, se, abs(mean) - cfg.significance * se > floor

    def pending_ids(self) -> np.ndarray:
        """(M,) int64: the landmarks of the keyframes not fitted yet (the only ones a later fit reads)."""
        return np.concatenate([g[1] for g in self.keyframes.values()] + [np.zeros(0, np.int64)])

    @property
    def median_disparity_px(self) -> float:
        """The median raw disparity ``f b / z`` (px) of the tracked landmarks (inf with none)."""
        if not self.births:
            return float("inf")
        return float(self.fb / np.median([z for _, z in self.births.values()]))

    @property
    def estimate_px(self) -> float:
        """The weighted mean of the keyframes' fits so far (nan before any), applied or not."""
        if not self.fits:
            return float("nan")
        w = 1.0 / np.array([max(f[1], 1e-6) for f in self.fits])
        return float(np.sum(w * np.array([f[0] for f in self.fits])) / np.sum(w))

    def rebase(self, moved: dict) -> None:
        """The chain re-estimated (:meth:`vo.estimators.offset_replay.Replay.moved`: old camera centre's bytes
        -> ``(T_new (4,4), R_new_old (3,3))``). The landmarks' birth centres, the pending keyframes (centre and
        rays) and the recorded poses whose centre was one of those (copies of the estimator's pose: equal to the
        bit) move with it."""
        self.births = {i: (moved[c.tobytes()][0][:3, 3].copy() if c.tobytes() in moved else c, z)
                       for i, (c, z) in self.births.items()}
        for k, (c, ids, dirs, z) in list(self.keyframes.items()):
            if c.tobytes() in moved:
                T_new, R_new_old = moved[c.tobytes()]
                self.keyframes[k] = (T_new[:3, 3].copy(), ids, dirs @ R_new_old.T, z)
        self.history = [(k, moved[T[:3, 3].tobytes()][0].copy() if T[:3, 3].tobytes() in moved else T, ids, x, m)
                        for k, T, ids, x, m in self.history]

    def correct(self, i: int, p_raw_o: np.ndarray) -> np.ndarray:
        """Landmark ``i``'s raw position ``p_raw_o`` (3,) moved along its birth ray to the depth the offset
        :attr:`delta_px` gives (unchanged while it is 0 or the landmark unknown)."""
        b = self.births.get(int(i))
        if self.delta_px == 0.0 or b is None:
            return p_raw_o
        z_new = self.fb / (self.fb / b[1] + self.delta_px)
        return b[0] + (p_raw_o - b[0]) * (z_new / b[1])

    def correct_all(self, raw_o: dict) -> dict:
        """:meth:`correct` of every landmark of ``raw_o`` ({id: raw position (3,)}) in one pass -> {id: position
        (3,)}, in the same order (the same arithmetic, element by element)."""
        known = [i for i in raw_o if i in self.births] if self.delta_px != 0.0 else []
        if not known:
            return dict(raw_o)
        c_b = np.array([self.births[i][0] for i in known])
        z = np.array([self.births[i][1] for i in known])
        z_new = self.fb / (self.fb / z + self.delta_px)
        moved = c_b + (np.array([raw_o[i] for i in known]) - c_b) * (z_new / z)[:, None]
        out = dict(raw_o)
        out.update(zip(known, moved))
        return out


def _seen(ids, frames) -> list:
    """The observations of the landmarks ``ids`` (M,) on ``frames`` ((frame, T_o_c0, ids, x_n) each) that
    :meth:`DisparityOffset.fit_keyframe` uses: ``[((frame, T_o_c0), landmark indices (K,), their points (K,2))]``
    for the frames that see at least :data:`MIN_FRAME_LANDMARKS` of them."""
    ids = np.asarray(ids, np.int64)
    order = np.argsort(ids)
    seen = []
    for fr in frames:
        pos = np.minimum(np.searchsorted(ids[order], fr[2]), len(ids) - 1)
        hit = ids[order][pos] == fr[2]
        if hit.sum() >= MIN_FRAME_LANDMARKS:
            seen.append((fr[:2], order[pos[hit]], fr[3][hit]))
    return seen
