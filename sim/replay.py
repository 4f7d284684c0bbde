"""Replay a recorded trajectory (TUM, EuRoC ground truth, KITTI poses) through a smooth SE(3) spline.

The motion *is* the spline fitted to the file's poses; every derivative is the spline's own, so the
IMU measured along it is exact for it (``vo-testbed validate imu`` integrates it back).

Construction (times in s from the file's first pose; world ``w`` is the file's reference frame):

* position: per axis a quintic B-spline (scipy ``make_lsq_spline``, ``k = 5``) fitted by least squares
  to the N poses on uniform knots ``knot_spacing_s`` apart (default 0.1 s, at least two of the longest
  input steps), or interpolating every pose (``make_interp_spline``) with ``knot_spacing_s = 0``. Quintic
  splines are C4, so ``v_w``, ``a_w`` and their derivative are continuous;
* rotation: the unit quaternions (signs made continuous, ``q_k . q_{k-1} >= 0``) are fitted, per
  component, by the same quintic spline ``s(t)``, and the rotation is the normalised
  ``q(t) = s(t) / |s(t)|``. Normalising a non-vanishing C4 curve is C4, so ``omega_b`` and
  ``alpha_b`` are continuous (C2 and beyond, as a cumulative cubic B-spline on SO(3) would be). With
  ``q' = 1/2 q (x) [0, omega_b]``: ``omega_b = 2 vec(q* (x) q')`` and ``alpha_b = 2 vec(q* (x) q'')``
  (the term ``q'* (x) q'`` is real), with ``q'``, ``q''`` from the quotient rule (exact);
* the poses may be of the body ``b`` (default), the IMU ``i`` or the left camera ``cam0``: the
  spline is fitted to the poses as given, then ``T_w_b = T_w_x T_x_b`` with the rig's extrinsics, and
  velocities and accelerations are carried to ``b`` exactly (rigid-body kinematics).

The fit is refused (one-line :class:`~sim.errors.SimError` naming the file and the time) when the
input has a gap longer than :data:`GAP_FACTOR` median steps, or when following it needs more than
:data:`MAX_ACCEL_MPS2`, :data:`MAX_RATE_RADPS` or :data:`MAX_ANG_ACCEL_RADPS2` (a jump: a pose
teleported, a quaternion flipped), or when the spline departs from a pose by more than
:data:`MAX_DEPARTURE_M` / :data:`MAX_DEPARTURE_DEG`.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Optional

import numpy as np
from scipy.interpolate import make_interp_spline, make_lsq_spline

from rigs.errors import RecordError
from rigs.geometry import R_from_quat_wxyz, quat_wxyz_from_R
from rigs.trajectory import Trajectory
from rigs.trajfile import read_trajectory
from rigs.typed_config import check_fields, knob
from sim.errors import SimError
from sim.motion import BodyStates, path_length_m

GAP_FACTOR = 5.0               # a step longer than 5 median steps is a gap
MAX_ACCEL_MPS2 = 100.0         # ~10 g: beyond any hand-held, drone or car motion
MAX_RATE_RADPS = 20.0          # ~3 turns per second
MAX_ANG_ACCEL_RADPS2 = 1000.0
MAX_DEPARTURE_M = 0.02        # a pose 2 cm off the least-squares spline is not noise
MAX_DEPARTURE_DEG = 1.0


@dataclass(frozen=True)
class ReplayConfig:
    """``--motion FILE`` (``replay.file``): replay its poses through a spline (see :mod:`sim.replay`).
    ``frame``: whose poses the file holds (``body``, ``imu`` or ``cam0``); ``fmt``: ``auto``, ``tum``,
    ``euroc`` or ``kitti`` (KITTI poses take ``times``, else ``times.txt`` beside them); ``up``: the file's world axis
    pointing up (``z``: EuRoC, TUM, ours; ``-y``: KITTI's first-camera frame, x right, y down, z forward,
    taken to w as z -> x, -x -> y, -y -> z); ``place``: ``file`` keeps the file's world as ``w``,
    ``start`` moves and turns it about z so the first body pose stands on the ground at the start of the
    scene's route, its x axis along the route; ``knot_spacing_s``: the spline's knots (0: through every
    pose)."""

    file: Optional[str] = None
    frame: Literal["body", "imu", "cam0"] = "body"
    fmt: Literal["auto", "tum", "euroc", "kitti"] = "auto"
    times: Optional[str] = None
    up: Literal["z", "-y"] = "z"
    place: Literal["file", "start"] = "file"
    knot_spacing_s: float = knob(0.1, ge=0.0, le=10.0, doc="knot spacing of the least-squares spline (s); 0 interpolates")

    def __post_init__(self):
        check_fields(self, SimError, "replay.")


@dataclass(frozen=True)
class Departure:
    """How far the spline is from the input poses: max and RMS, position (m) and angle (deg), at the
    input times; ``t_max_s`` / ``t_max_ang_s`` the times (s from the first pose) of the largest ones."""

    n_poses: int
    pos_max_m: float
    pos_rms_m: float
    ang_max_deg: float
    ang_rms_deg: float
    t_max_s: float
    t_max_ang_s: float = 0.0

    def to_dict(self) -> dict:
        return {k: (int(v) if k == "n_poses" else float(v)) for k, v in self.__dict__.items()}

    def text(self) -> str:
        return (f"spline departs from the {self.n_poses} input poses by max {self.pos_max_m * 1e3:.3g} mm "
                f"(RMS {self.pos_rms_m * 1e3:.3g} mm), max {self.ang_max_deg:.3g} deg (RMS {self.ang_rms_deg:.3g} deg)")


def _qmul(a, b):
    """Hamilton product of (..., 4) wxyz quaternions."""
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def _conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


class _VecSpline:
    """Quintic splines of (N, C) values at times t (N,) s: least squares on uniform knots ``spacing`` s apart
    (at least two of the longest input steps, so every knot span holds poses), or interpolating every
    pose when ``spacing`` is 0; call -> value, d1, d2 (M, C)."""

    def __init__(self, t: np.ndarray, y: np.ndarray, spacing: float):
        if spacing > 0:
            dk = max(spacing, 2.0 * float(np.diff(t).max()))
            n_in = max(0, int(math.floor(t[-1] / dk - 0.5)))
            inner = np.linspace(0.0, t[-1], n_in + 2)[1:-1]
            knots = np.r_[[t[0]] * 6, inner, [t[-1]] * 6]
            self._f = make_lsq_spline(t, y, knots, k=5, axis=0)
        else:
            self._f = make_interp_spline(t, y, k=5, axis=0)
        self._d = [self._f.derivative(k) for k in (1, 2)]

    def __call__(self, t):
        return [self._f(t), self._d[0](t), self._d[1](t)]


class ReplayTrajectory:
    """A trajectory replayed from poses: :meth:`states` at any int64 ns time in ``[t0_ns, t1_ns]``.

    Same interface as :class:`sim.motion.VehicleTrajectory` (``states``, ``path_length``,
    ``pass_times_ns``, ``to_trajectory``). The file's first pose is placed at ``t0_ns``."""

    def __init__(self, poses: Trajectory, T_x_b: np.ndarray, t0_ns: int, knot_spacing_s: float = 0.1,
                 duration_s=None, source: str = "poses", source_sha256: str = ""):
        self.source, self.source_sha256 = source, source_sha256
        t_in = (poses.t_ns - poses.t_ns[0]).astype(float) * 1e-9
        self._t_in, self._T_in, self._file_t0_ns = t_in, poses.T, int(poses.t_ns[0])
        _check_gaps(t_in, source, self._file_t0_ns)
        q = quat_wxyz_from_R(poses.rotations)
        flip = np.cumprod(np.where(np.einsum("ij,ij->i", q[1:], q[:-1]) < 0, -1.0, 1.0))
        q[1:] *= flip[:, None]
        try:
            self._pos = _VecSpline(t_in, poses.positions, knot_spacing_s)
            self._quat = _VecSpline(t_in, q, knot_spacing_s)
        except (ValueError, np.linalg.LinAlgError) as e:
            raise SimError(f"replay.file: {source}: no spline fits these poses ({e})") from None
        self._T_x_b = np.asarray(T_x_b, dtype=float)
        self.t0_ns = int(t0_ns)
        dur = float(t_in[-1])
        if duration_s is not None:
            dur = min(dur, float(duration_s))
        self.t1_ns = self.t0_ns + int(round(dur * 1e9))
        self.departure = self._departure()
        self._check_follows()

    @classmethod
    def from_config(cls, cfg: ReplayConfig, rig, t0_ns: int, duration_s=None, scene=None) -> "ReplayTrajectory":
        """Read ``cfg.file``, take it to ``w`` (``up``, ``place``: the scene's route start) and fit; the rig
        gives ``T_x_b`` for ``frame`` imu or cam0."""
        try:
            poses = read_trajectory(cfg.file, cfg.fmt, cfg.times)
        except RecordError as e:
            msg = str(e).replace("with --times FILE", "with --motion-times FILE (replay.times)")
            raise SimError(f"replay.file: {msg}") from None
        T_b_x = {"body": np.eye(4), "imu": rig.imu.T_b_i_array, "cam0": rig.cameras[0].T_b_c_array}[cfg.frame]
        T_w_f = np.eye(4)
        if cfg.up == "-y":
            T_w_f[:3, :3] = UP_MINUS_Y
        if cfg.place == "start":
            if scene is None:
                raise SimError("replay.place: 'start' needs the scene (its route's start)")
            T_w_f = _start_placement(scene, T_w_f @ poses.T[0] @ np.linalg.inv(T_b_x)) @ T_w_f
        poses = Trajectory(poses.t_ns, T_w_f @ poses.T, "w", poses.frame)
        sha = hashlib.sha256(Path(cfg.file).read_bytes()).hexdigest()
        return cls(poses, np.linalg.inv(T_b_x), t0_ns, cfg.knot_spacing_s, duration_s,
                   source=str(cfg.file), source_sha256=sha)

    def metadata(self) -> dict:
        """``metadata.yaml``'s ``replay`` block: the file's SHA-256 (the config records only its path) and
        the spline's departure from its poses."""
        return {"source_sha256": self.source_sha256, "departure": self.departure.to_dict()}

    # ------------------------------------------------------------------ evaluation
    def _spline_states(self, t: np.ndarray):
        """Frame x of the file at t (M,) s: R (M,3,3), p, v, a (M,3), omega_x, alpha_x (M,3) in x."""
        p, v, a = self._pos(t)
        s, s1, s2 = self._quat(t)
        n2 = np.einsum("ij,ij->i", s, s)
        n = np.sqrt(n2)
        ss1 = np.einsum("ij,ij->i", s, s1)
        u = 1.0 / n
        u1 = -ss1 / n ** 3
        u2 = -(np.einsum("ij,ij->i", s1, s1) + np.einsum("ij,ij->i", s, s2)) / n ** 3 + 3 * ss1 ** 2 / n ** 5
        q = s * u[:, None]
        q1 = s1 * u[:, None] + s * u1[:, None]
        q2 = s2 * u[:, None] + 2 * s1 * u1[:, None] + s * u2[:, None]
        om = 2 * _qmul(_conj(q), q1)[:, 1:]
        al = 2 * _qmul(_conj(q), q2)[:, 1:]
        return R_from_quat_wxyz(q), p, v, a, om, al

    def _rel_s(self, t_ns) -> np.ndarray:
        return (np.asarray(t_ns, dtype=np.int64).reshape(-1) - np.int64(self.t0_ns)).astype(float) * 1e-9

    def states(self, t_ns) -> BodyStates:
        """Exact pose, velocities and accelerations of ``b`` at ``t_ns`` (N,) int64."""
        t_ns = np.asarray(t_ns, dtype=np.int64).reshape(-1)
        R, p, v, a, om_x, al_x = self._spline_states(self._rel_s(t_ns))
        R_x_b, r_x = self._T_x_b[:3, :3], self._T_x_b[:3, 3]           # b's origin at r_x in x
        r_w = R @ r_x
        om_w, al_w = np.einsum("nij,nj->ni", R, om_x), np.einsum("nij,nj->ni", R, al_x)
        T = np.zeros((t_ns.size, 4, 4))
        T[:, :3, :3] = R @ R_x_b
        T[:, :3, 3] = p + r_w
        T[:, 3, 3] = 1.0
        v_b = v + np.cross(om_w, r_w)
        a_b = a + np.cross(al_w, r_w) + np.cross(om_w, np.cross(om_w, r_w))
        R_b_x = R_x_b.T
        return BodyStates(t_ns, T, v_b, a_b, om_x @ R_b_x.T, al_x @ R_b_x.T)

    # ------------------------------------------------------------------ checks
    def _departure(self) -> Departure:
        R, p, *_ = self._spline_states(self._t_in)
        dp = np.linalg.norm(p - self._T_in[:, :3, 3], axis=1)
        dR = np.einsum("nji,njk->nik", R, self._T_in[:, :3, :3])
        sin = np.linalg.norm(np.stack([dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0],
                                       dR[:, 1, 0] - dR[:, 0, 1]], axis=1), axis=1) / 2
        ang = np.degrees(np.arctan2(sin, (np.trace(dR, axis1=1, axis2=2) - 1) / 2))   # exact near 0 too
        k, j = int(np.argmax(dp)), int(np.argmax(ang))
        return Departure(len(dp), float(dp.max()), float(np.sqrt(np.mean(dp ** 2))), float(ang.max()),
                         float(np.sqrt(np.mean(ang ** 2))), float(self._t_in[k]), float(self._t_in[j]))

    def _check_follows(self) -> None:
        """Refuse a jump: limits on the spline's acceleration and rates, and on its departure."""
        t = np.linspace(0.0, self._t_in[-1], max(2, int(self._t_in[-1] * 400) + 1))
        _, _, _, a, om, al = self._spline_states(t)
        for name, val, lim, unit in (("acceleration", np.linalg.norm(a, axis=1), MAX_ACCEL_MPS2, "m/s^2"),
                                     ("angular rate", np.linalg.norm(om, axis=1), MAX_RATE_RADPS, "rad/s"),
                                     ("angular acceleration", np.linalg.norm(al, axis=1), MAX_ANG_ACCEL_RADPS2,
                                      "rad/s^2")):
            k = int(np.argmax(val))
            if val[k] > lim:
                raise SimError(f"replay.file: {self.source}: a jump at {_when(t[k], self._file_t0_ns)}: "
                               f"following it needs {name} {val[k]:.3g} {unit} (limit {lim:g}); the spline cannot "
                               f"follow it")
        d = self.departure
        lim_m, lim_deg = MAX_DEPARTURE_M, MAX_DEPARTURE_DEG
        if d.pos_max_m > lim_m or d.ang_max_deg > lim_deg:
            t_bad = d.t_max_s if d.pos_max_m > lim_m else d.t_max_ang_s
            raise SimError(f"replay.file: {self.source}: a jump at {_when(t_bad, self._file_t0_ns)}: "
                           f"the spline departs {d.pos_max_m:.3g} m / {d.ang_max_deg:.3g} deg from the poses "
                           f"(limit {lim_m:g} m / {lim_deg:g} deg); the spline cannot follow it")

    # ------------------------------------------------------------------ interface of VehicleTrajectory
    def path_length(self) -> float:
        """3-D length (m) of the body origin's path over [t0_ns, t1_ns] (Gauss-Legendre on |v_w|)."""
        return path_length_m(self.states, self.t0_ns, self.t1_ns)

    def pass_times_ns(self, points_xy) -> np.ndarray:
        """(K,2) world points -> (K,) int64 times (1 ms grid) the body origin passes closest in x, y."""
        P = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        t = np.arange(self.t0_ns, self.t1_ns + 1, 1_000_000, dtype=np.int64)
        xy = self.states(t).T_w_b[:, :2, 3]
        d2 = ((xy[None, :, :] - P[:, None, :]) ** 2).sum(-1)
        return t[np.argmin(d2, axis=1)]

    def to_trajectory(self, t_ns) -> Trajectory:
        st = self.states(t_ns)
        return Trajectory(st.t_ns, st.T_w_b, ref="w", frame="b")


UP_MINUS_Y = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])   # KITTI c0_0 -> z up


def _start_placement(scene, T_w_b0: np.ndarray) -> np.ndarray:
    """(4,4) turn about z and shift taking the first body pose ``T_w_b0`` to the route's first waypoint,
    on the ground there, its x axis (projected on the ground plane) along the route's first leg."""
    wp = np.asarray(scene.route.waypoints_xy, dtype=float)
    d = wp[1] - wp[0]
    x_b = T_w_b0[:3, 0]
    yaw = math.atan2(d[1], d[0]) - math.atan2(x_b[1], x_b[0])
    c, s = math.cos(yaw), math.sin(yaw)
    T = np.eye(4)
    T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    z0 = float(scene.ground_height(wp[0, 0], wp[0, 1]))
    T[:3, 3] = np.array([wp[0, 0], wp[0, 1], z0]) - T[:3, :3] @ T_w_b0[:3, 3]
    return T


def _when(t_s: float, file_t0_ns: int) -> str:
    """``t = 2.970 s (file time 1403636582.733 s)``: from the first pose, and on the file's clock."""
    return f"t = {t_s:.3f} s (file time {(file_t0_ns + round(t_s * 1e9)) * 1e-9:.3f} s)"


def _check_gaps(t: np.ndarray, source: str, file_t0_ns: int = 0) -> None:
    if t.size < 8:
        raise SimError(f"replay.file: {source}: {t.size} poses; a spline needs at least 8")
    dt = np.diff(t)
    med = float(np.median(dt))
    k = int(np.argmax(dt))
    if dt[k] > GAP_FACTOR * med:
        raise SimError(f"replay.file: {source}: a gap of {dt[k]:.3f} s after {_when(t[k], file_t0_ns)} ("
                       f"median step {med:.4f} s, limit {GAP_FACTOR:g} steps); the spline cannot follow it")
