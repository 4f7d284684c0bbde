"""Exact IMU samples (MuJoCo accelerometer + gyro at an IMU site) and a high-order IMU integrator.

Measurement model (``CONVENTIONS.md``): ``accel = R_i_w (a_w_i - g_w)`` (specific force at the
IMU origin, in i), ``gyro = R_i_b omega_b`` (noise-free; see ``sim.sensors.imu_noise`` for noise).
MuJoCo evaluates both with ``mj_inverse`` on a one-body model whose free joint is set to the
trajectory's state: ``qpos = [t_w_b, quat_wxyz(R_w_b)]``, ``qvel = [v_w, omega_b]``,
``qacc = [a_w, alpha_b]`` (free joint: linear parts in the world frame, angular parts in the
body frame; checked against the analytic formula in ``tests/test_imu_exact.py``).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from sim.errors import SimError
from rigs.geometry import R_from_quat_wxyz, quat_wxyz_from_R
from rigs.records import ImuSamples

G_W = np.array([0.0, 0.0, -9.81])


def imu_times_ns(t0_ns: int, t1_ns: int, rate_hz: float) -> np.ndarray:
    """(N,) int64 sample times ``t0 + round(k * 1e9 / rate)`` in [t0, t1] (exact for rates dividing 1e9)."""
    if not rate_hz > 0 or t1_ns < t0_ns:
        raise SimError(f"imu_times_ns: need rate_hz > 0 and t1 >= t0, got rate {rate_hz!r}, [{t0_ns}, {t1_ns}]")
    period = 1e9 / float(rate_hz)
    k = np.arange(int((t1_ns - t0_ns) // period) + 2, dtype=np.int64)
    t = np.int64(t0_ns) + np.round(k * period).astype(np.int64)
    return t[t <= t1_ns]


@lru_cache(maxsize=16)
def _imu_model(T_b_i: tuple):
    """MuJoCo model: one free body (frame b) with the IMU site at ``T_b_i``, accelerometer + gyro."""
    import mujoco
    T = np.array(T_b_i, dtype=float)
    pos = " ".join(repr(float(x)) for x in T[:3, 3])
    quat = " ".join(repr(float(x)) for x in quat_wxyz_from_R(T[:3, :3]))
    xml = f"""<mujoco model="imu_probe">
  <option gravity="{' '.join(repr(float(g)) for g in G_W)}"/>
  <worldbody><body name="b"><freejoint/>
    <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
    <site name="imu" pos="{pos}" quat="{quat}"/>
  </body></worldbody>
  <sensor><accelerometer name="accel" site="imu"/><gyro name="gyro" site="imu"/></sensor>
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def measure_states(states, T_b_i: np.ndarray) -> ImuSamples:
    """Exact IMU samples for ``BodyStates`` (from ``VehicleTrajectory.states``) via ``mj_inverse``."""
    import mujoco
    model = _imu_model(tuple(map(tuple, np.asarray(T_b_i, dtype=float))))
    data = mujoco.MjData(model)
    n = states.t_ns.shape[0]
    qpos = np.concatenate([states.T_w_b[:, :3, 3], quat_wxyz_from_R(states.T_w_b[:, :3, :3])], axis=1)
    qvel = np.concatenate([states.v_w, states.omega_b], axis=1)
    qacc = np.concatenate([states.a_w, states.alpha_b], axis=1)
    out = np.empty((n, 6))
    adr_a, adr_g = model.sensor("accel").adr[0], model.sensor("gyro").adr[0]
    for k in range(n):
        data.qpos[:], data.qvel[:], data.qacc[:] = qpos[k], qvel[k], qacc[k]
        mujoco.mj_inverse(model, data)
        out[k, :3] = data.sensordata[adr_g:adr_g + 3]
        out[k, 3:] = data.sensordata[adr_a:adr_a + 3]
    return ImuSamples(states.t_ns.copy(), out[:, :3].copy(), out[:, 3:].copy())


def measure(truth, imu) -> ImuSamples:
    """The IMU's clean measurement step: exact samples of ``imu`` (rigs.Imu, pose ``T_b_i``) for the
    body states ``truth`` (``BodyStates``); the noise step is :func:`sim.sensors.imu_noise.add_imu_noise`."""
    return measure_states(truth, imu.T_b_i_array)


def measure_imu(trajectory, imu, t_ns) -> ImuSamples:
    """Exact (noise-free) samples of ``imu`` (rigs.Imu, pose ``T_b_i``) on ``trajectory`` at ``t_ns``."""
    return measure(trajectory.states(t_ns), imu)


def analytic_imu(states, T_b_i: np.ndarray) -> ImuSamples:
    """Closed form: ``accel = R_i_w (a_w + alpha x r + omega x (omega x r) - g_w)``, r = lever arm in w."""
    T_b_i = np.asarray(T_b_i, dtype=float)
    R_w_b = states.T_w_b[:, :3, :3]
    r_b = T_b_i[:3, 3]
    a_b = np.cross(states.alpha_b, r_b) + np.cross(states.omega_b, np.cross(states.omega_b, r_b))
    a_w_i = states.a_w + np.einsum("nij,nj->ni", R_w_b, a_b)
    f_b = np.einsum("nji,nj->ni", R_w_b, a_w_i - G_W)
    R_i_b = T_b_i[:3, :3].T
    return ImuSamples(states.t_ns.copy(), states.omega_b @ R_i_b.T, f_b @ R_i_b.T)


def imu_pose_velocity(states, T_b_i: np.ndarray):
    """True IMU pose ``T_w_i`` (N,4,4) and IMU-origin velocity ``v_w_i`` (N,3)."""
    T_b_i = np.asarray(T_b_i, dtype=float)
    T_w_i = states.T_w_b @ T_b_i
    v_b = np.cross(states.omega_b, T_b_i[:3, 3])
    return T_w_i, states.v_w + np.einsum("nij,nj->ni", states.T_w_b[:, :3, :3], v_b)


# ----------------------------------------------------------------------------- integration
def _midpoints(f: np.ndarray, order: int = 6) -> np.ndarray:
    """(N,C) uniformly sampled -> (N-1,C) values at interval midpoints by ``order``-point Lagrange.

    Stencils are centred where possible and one-sided at the ends; error O(h^order).
    """
    n = f.shape[0]
    m = min(order, n)
    k = np.arange(n - 1)
    j0 = np.clip(k - (m // 2 - 1), 0, n - m)
    x = k + 0.5 - j0                                   # midpoint position inside its stencil
    nodes = np.arange(m)
    out = np.zeros((n - 1, f.shape[1]))
    for j in range(m):
        others = nodes[nodes != j]
        w = np.prod((x[:, None] - others) / (j - others), axis=1)
        out += w[:, None] * f[j0 + j]
    return out


def _rk4_step(q, v, p, u0, um, u1, h, g):
    """One RK4 step of q' = q (x) (0, w) / 2, v' = R(q) f + g, p' = v; plain floats for speed.

    q (4,) wxyz, v, p (3,), u* = (wx, wy, wz, fx, fy, fz) at t, t + h/2, t + h."""
    def f(q_, v_, u):
        w0, x, y, z = q_
        wx, wy, wz, ax, ay, az = u
        dq = (0.5 * (-x * wx - y * wy - z * wz), 0.5 * (w0 * wx + y * wz - z * wy),
              0.5 * (w0 * wy - x * wz + z * wx), 0.5 * (w0 * wz + x * wy - y * wx))
        acc = ((1 - 2 * (y * y + z * z)) * ax + 2 * (x * y - w0 * z) * ay + 2 * (x * z + w0 * y) * az + g[0],
               2 * (x * y + w0 * z) * ax + (1 - 2 * (x * x + z * z)) * ay + 2 * (y * z - w0 * x) * az + g[1],
               2 * (x * z - w0 * y) * ax + 2 * (y * z + w0 * x) * ay + (1 - 2 * (x * x + y * y)) * az + g[2])
        return dq, acc, v_

    def add(a, b, c):
        return tuple(ai + c * bi for ai, bi in zip(a, b))

    k1 = f(q, v, u0)
    k2 = f(add(q, k1[0], h / 2), add(v, k1[1], h / 2), um)
    k3 = f(add(q, k2[0], h / 2), add(v, k2[1], h / 2), um)
    k4 = f(add(q, k3[0], h), add(v, k3[1], h), u1)
    out = []
    for x, i in ((q, 0), (v, 1), (p, 2)):
        out.append(tuple(x[j] + h / 6 * (k1[i][j] + 2 * k2[i][j] + 2 * k3[i][j] + k4[i][j]) for j in range(len(x))))
    qn = out[0]
    norm = (qn[0] ** 2 + qn[1] ** 2 + qn[2] ** 2 + qn[3] ** 2) ** 0.5
    return tuple(c / norm for c in qn), out[1], out[2]


def integrate_imu(samples: ImuSamples, T_w_i0: np.ndarray, v_w0: np.ndarray, g_w=G_W):
    """Dead-reckon noise-free IMU samples: RK4 on (q_w_i, v_w, p_w) with 6-point-Lagrange midpoints.

    Needs uniform sampling. Returns ``T_w_i`` (N,4,4) and ``v_w`` (N,3) at every sample time.
    """
    t = np.asarray(samples.t_ns, dtype=np.int64)
    if t.size < 2 or np.any(np.diff(t) != t[1] - t[0]):
        raise SimError("integrate_imu: samples must be at least two, uniformly spaced in t_ns")
    h = (t[1] - t[0]) * 1e-9
    f = np.concatenate([samples.gyro, samples.accel], axis=1)
    mid = _midpoints(f)
    g = tuple(float(x) for x in g_w)
    q = tuple(quat_wxyz_from_R(np.asarray(T_w_i0)[:3, :3]).tolist())
    v, p = tuple(float(x) for x in v_w0), tuple(np.asarray(T_w_i0, dtype=float)[:3, 3].tolist())
    f_l, mid_l = f.tolist(), mid.tolist()
    qs, vs, ps = [q], [v], [p]
    for k in range(t.size - 1):
        q, v, p = _rk4_step(q, v, p, f_l[k], mid_l[k], f_l[k + 1], h, g)
        qs.append(q), vs.append(v), ps.append(p)
    T_out = np.zeros((t.size, 4, 4))
    T_out[:, :3, :3] = R_from_quat_wxyz(np.array(qs))
    T_out[:, :3, 3], T_out[:, 3, 3] = np.array(ps), 1.0
    return T_out, np.array(vs)
