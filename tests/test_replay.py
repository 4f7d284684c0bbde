"""Replayed motion (sim.replay): exact spline derivatives, C2 continuity at knots, IMU exactness, the
frame of the poses, the departure figure, refusals of gaps and jumps, and the wheel-less vehicles."""
import hashlib
import os
import subprocess
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest
import yaml

from rigs.geometry import R_from_opk_deg, make_T, quat_wxyz_from_R, so3_log
from rigs.model import Imu
from rigs.trajectory import Trajectory
from rigs.trajfile import write_kitti, write_tum
from sim.generate_config import GenerateConfig, rig_of
from sim.errors import SimError
from sim.replay import ReplayConfig, ReplayTrajectory
from sim.replay_paths import hand_walk, helix
from sim.vehicles import make_vehicle
from sim.sensors.imu import imu_pose_velocity, imu_times_ns, integrate_imu, measure_states

T0 = 1_000_000_000
IMU = Imu(T_b_i=make_T(R_from_opk_deg(10, -20, 95), [0.3, -0.2, 0.8]), rate_hz=200.0)


@pytest.fixture(scope="module")
def walk():
    return ReplayTrajectory(hand_walk(seed=3, duration_s=6.0), np.eye(4), T0)


def _fd_check(tr, t, h_ns=100_000):
    """Central differences (step 2h = 0.2 ms) of pose -> v, omega; of v, omega -> a, alpha. Truncation error
    ~ h^2 |f'''| / 6 ~ 1e-8 |f'''| and rounding ~ 1e-16 |f| / h ~ 1e-12: bounds 1e-6 on O(1) signals."""
    s0, sp, sm = tr.states(t), tr.states(t + h_ns), tr.states(t - h_ns)
    h2 = 2 * h_ns * 1e-9
    v_fd = (sp.T_w_b[:, :3, 3] - sm.T_w_b[:, :3, 3]) / h2
    om_fd = np.array([so3_log(a[:3, :3].T @ b[:3, :3]) for a, b in zip(sm.T_w_b, sp.T_w_b)]) / h2
    return (np.abs(v_fd - s0.v_w).max(), np.abs((sp.v_w - sm.v_w) / h2 - s0.a_w).max(),
            np.abs(om_fd - s0.omega_b).max(), np.abs((sp.omega_b - sm.omega_b) / h2 - s0.alpha_b).max(), s0)


def test_derivatives_equal_finite_differences(walk):
    t = np.arange(walk.t0_ns + 50_000_000, walk.t1_ns - 50_000_000, 7_000_000)
    dv, da, dom, dal, s0 = _fd_check(walk, t)
    assert np.abs(s0.a_w).max() > 0.5 and np.abs(s0.alpha_b).max() > 1.0   # a real, lively motion
    assert dv < 1e-6 and da < 1e-6 and dom < 1e-6 and dal < 1e-5


def test_cam0_poses_give_body_motion_with_exact_derivatives():
    """Poses of cam0 (lever 1.2 m, rotated): T_w_b T_b_c0 is the spline through the cam0 poses, and the
    body's v, a, omega, alpha (rigid-body transfer) still equal finite differences."""
    rig = rig_of("cart27")
    T_b_c = rig.cameras[0].T_b_c_array
    body = hand_walk(seed=5, duration_s=4.0)
    cam = Trajectory(body.t_ns, body.T @ T_b_c, "w", "c0")
    tr = ReplayTrajectory(cam, np.linalg.inv(T_b_c), T0, knot_spacing_s=0.0)
    T_wc = tr.states(T0 + (body.t_ns - body.t_ns[0])).T_w_b @ T_b_c
    assert np.abs(T_wc - cam.T).max() < 1e-9                   # knot spacing 0: interpolates the poses
    t = np.arange(tr.t0_ns + 50_000_000, tr.t1_ns - 50_000_000, 9_000_000)
    dv, da, dom, dal, _ = _fd_check(tr, t)
    assert dv < 1e-6 and da < 1e-5 and dom < 1e-6 and dal < 1e-5


def test_c2_continuous_at_knots(walk):
    """Across every interior knot of the position and quaternion splines, a_w and alpha_b jump by no more
    than their slope allows over +-1 us (quintic: C4; a C1 spline would jump by O(1) m/s^2 here)."""
    knots = np.unique(np.concatenate([f.t[6:-6] for f in (walk._pos._f, walk._quat._f)]))
    knots = knots[(knots > 0.01) & (knots < 5.99)]
    assert knots.size > 50                              # knots every 0.1 s over 6 s
    t = T0 + np.round(knots * 1e9).astype(np.int64)
    lo, hi = walk.states(t - 1000), walk.states(t + 1000)
    assert np.abs(hi.a_w - lo.a_w).max() < 1e-3            # |jerk| < ~100 m/s^3 over 2 us
    assert np.abs(hi.alpha_b - lo.alpha_b).max() < 1e-3


def test_ideal_imu_integrates_back_to_the_spline():
    """5 s helix, IMU 0.9 m from b and rotated, 200 Hz exact samples, RK4 of sim.sensors.imu: the same check
    and integrator as the routes (tests/test_imu_exact.py, limits 1 cm, 0.01 deg). Measured ~1e-11 m."""
    tr = ReplayTrajectory(helix(duration_s=5.0), np.eye(4), T0)
    t = imu_times_ns(tr.t0_ns, tr.t1_ns, IMU.rate_hz)
    st = tr.states(t)
    T_w_i, v_w_i = imu_pose_velocity(st, IMU.T_b_i_array)
    T_est, v_est = integrate_imu(measure_states(st, IMU.T_b_i_array), T_w_i[0], v_w_i[0])
    pos_err = np.linalg.norm(T_est[-1, :3, 3] - T_w_i[-1, :3, 3])
    att_err = np.degrees(np.linalg.norm(so3_log(T_est[-1, :3, :3].T @ T_w_i[-1, :3, :3])))
    assert pos_err < 1e-6 and att_err < 1e-6
    assert np.abs(v_est - v_w_i).max() < 1e-6
    assert tr.path_length() > 3.0


def test_departure_reflects_the_noise_and_the_fit_removes_it():
    """Noise of 2 mm per axis and 0.2 deg on a 100 Hz helix, knots every 0.1 s (10 poses per knot span):
    the least-squares spline departs from the poses by about the noise (RMS 3.5 mm expected in 3-D, less
    the ~6 % of the noise the spline's 66 coefficients absorb) and is closer to the noise-free helix than
    the noisy poses are (by ~ sqrt(66 / 601) = 0.33: bound 0.5)."""
    h = helix(duration_s=6.0)
    rng = np.random.default_rng(1)
    T = h.T.copy()
    T[:, :3, 3] += rng.normal(0, 0.002, (len(h), 3))
    T[:, :3, :3] = T[:, :3, :3] @ np.stack([R_from_opk_deg(*a) for a in rng.normal(0, 0.2 / np.sqrt(3), (len(h), 3))])
    tr = ReplayTrajectory(Trajectory(h.t_ns, T, "w", "b"), np.eye(4), T0, knot_spacing_s=0.1)
    d = tr.departure
    assert 0.003 < d.pos_rms_m < 0.0036 and 0.15 < d.ang_rms_deg < 0.21
    truth = h.T[:, :3, 3]
    spl = tr.states(T0 + (h.t_ns - h.t_ns[0])).T_w_b[:, :3, 3]
    rms = lambda e: np.sqrt(np.mean(np.sum(e ** 2, 1)))                     # noqa: E731
    assert rms(spl - truth) < 0.5 * rms(T[:, :3, 3] - truth)


def _with(h, T=None, keep=None):
    T = h.T if T is None else T
    keep = np.ones(len(h), bool) if keep is None else keep
    return Trajectory(h.t_ns[keep], T[keep], "w", "b")


def test_refuses_gaps_jumps_and_flips_naming_the_time():
    h = helix(duration_s=6.0)                                  # 100 Hz, file times from 1 s
    keep = np.ones(len(h), bool)
    keep[300:340] = False
    with pytest.raises(SimError, match=r"a gap of 0\.410 s after t = 2\.990 s \(file time 3\.990 s\)"):
        ReplayTrajectory(_with(h, keep=keep), np.eye(4), T0)
    T = h.T.copy()
    T[250, 0, 3] += 0.3                                        # one pose teleported 30 cm
    with pytest.raises(SimError, match=r"a jump at t = 2\.500 s \(file time 3\.500 s\): the spline departs 0\.2\d\d m"):
        ReplayTrajectory(_with(h, T), np.eye(4), T0)
    T = h.T.copy()
    T[400, :3, :3] = T[400, :3, :3] @ R_from_opk_deg(0, 0, 60)  # one attitude off by 60 deg
    with pytest.raises(SimError, match=r"a jump at t = 4\.000 s .* departs .* deg"):
        ReplayTrajectory(_with(h, T), np.eye(4), T0)
    with pytest.raises(SimError, match="4 poses; a spline needs at least 8"):
        ReplayTrajectory(_with(h, keep=np.arange(len(h)) < 4), np.eye(4), T0)


def test_wheelless_vehicles_build_and_refuse_wheel_encoders():
    import mujoco
    for kind in ("handheld", "drone"):
        spec = mujoco.MjSpec()
        handles = make_vehicle(kind, rig_of("cart27")).add_to(spec)
        model = spec.compile()
        assert handles.kind == kind and model.ngeom >= 2 and len(handles.camera_names) == 2
        assert GenerateConfig(vehicle=kind).vehicle == kind
    with pytest.raises(SimError, match="'drone' has no wheels, but rig 'cart27' has wheel encoders"):
        GenerateConfig(vehicle="drone").with_overrides(["wheels=default"])


EXE = [sys.executable, "-c", "import sys; from sim.app.cli import main; sys.argv[0] = 'vo-testbed'; main()"]


@pytest.mark.slow
def test_cli_replays_and_refuses_in_one_line(tmp_path):
    """generate --motion prints the departure and writes it to metadata; a gap exits 2 with one line."""
    env = {**os.environ, "MUJOCO_GL": "egl"}
    good, bad = tmp_path / "helix.txt", tmp_path / "gap.txt"
    h = helix(duration_s=3.0)
    write_tum(good, h)
    keep = np.ones(len(h), bool)
    keep[100:120] = False
    write_tum(bad, _with(h, keep=keep))
    r = subprocess.run(EXE + ["generate", "--scene", "indoor", "--vehicle", "handheld", "--motion", str(good),
                              "--no-images", "--ideal", "--no-progress", "--out", str(tmp_path / "ds")],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "spline departs from the 301 input poses by max" in r.stdout
    meta = yaml.safe_load((tmp_path / "ds" / "metadata.yaml").read_text())
    dep = meta["replay"]["departure"]
    assert dep["n_poses"] == 301 and meta["config"]["replay"]["file"] == str(good)
    assert meta["replay"]["source_sha256"] == hashlib.sha256(good.read_bytes()).hexdigest()
    assert 0 < dep["pos_max_m"] < 1e-4                # a smooth helix: the spline is within 0.1 mm
    r = subprocess.run(EXE + ["generate", "--scene", "indoor", "--vehicle", "handheld", "--motion", str(bad),
                              "--no-images", "--no-progress", "--out", str(tmp_path / "ds2")],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert "a gap of 0.210 s after t = 0.990 s" in r.stderr and str(bad) in r.stderr
    assert not (tmp_path / "ds2" / "metadata.yaml").exists()


@pytest.mark.parametrize("fmt", ["tum", "euroc", "kitti"])
def test_every_format_and_frame_replays_the_same_body_motion(tmp_path, fmt):
    """The walk's poses of the IMU (EuRoC), cam0 (KITTI with times.txt) or the body (TUM), read through
    rigs.trajfile and carried to b with the rig's extrinsics: the same body poses, to the file's 9 digits."""
    rig = rig_of("cart27")
    body = hand_walk(seed=2, duration_s=3.0)
    T_b_x = {"tum": np.eye(4), "euroc": rig.imu.T_b_i_array, "kitti": rig.cameras[0].T_b_c_array}[fmt]
    frame = {"tum": "body", "euroc": "imu", "kitti": "cam0"}[fmt]
    poses = Trajectory(body.t_ns, body.T @ T_b_x, "w", "x")
    path = tmp_path / "poses.txt"
    if fmt == "tum":
        write_tum(path, poses)
    elif fmt == "kitti":
        write_kitti(path, poses, tmp_path / "times.txt")
    else:
        q = quat_wxyz_from_R(poses.rotations)
        path = tmp_path / "data.csv"
        path.write_text("#timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z\n" + "".join(
            f"{t},{p[0]:.9f},{p[1]:.9f},{p[2]:.9f},{a[0]:.9f},{a[1]:.9f},{a[2]:.9f},{a[3]:.9f}\n"
            for t, p, a in zip(poses.t_ns, poses.positions, q)))
    cfg = ReplayConfig(file=str(path), frame=frame, knot_spacing_s=0.0)
    tr = ReplayTrajectory.from_config(cfg, rig, T0)
    T = tr.states(T0 + (body.t_ns - body.t_ns[0])).T_w_b
    assert np.abs(T[:, :3, 3] - body.positions).max() < 1e-6
    assert np.abs(T[:, :3, :3] - body.rotations).max() < 1e-6


def test_up_and_place_put_a_kitti_like_file_upright_at_the_route_start(tmp_path):
    """Poses of cam0 in KITTI's first-camera frame (y down, z forward): with up=-y and place=start the
    first body pose stands on the ground (z = ground height) at the route's first waypoint, upright
    (body z = world z), its x axis along the first leg; the relative motion is unchanged."""
    from scenes.base import Route

    class FlatScene:
        route = Route(((3.0, 4.0), (3.0, 10.0)))

        @staticmethod
        def ground_height(x, y):
            return 0.25

    rig = rig_of("kitti-like")
    T_b_c = rig.cameras[0].T_b_c_array
    body = hand_walk(seed=4, duration_s=3.0)                    # z-up body poses
    R_kitti_w = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])   # inverse of UP_MINUS_Y
    T_k_w = np.eye(4)
    T_k_w[:3, :3] = R_kitti_w
    cam = Trajectory(body.t_ns, T_k_w @ body.T @ T_b_c, "c0_0", "c0")
    path = tmp_path / "00.txt"
    write_kitti(path, cam, tmp_path / "times.txt")
    cfg = ReplayConfig(file=str(path), frame="cam0", up="-y", place="start", knot_spacing_s=0.0)
    tr = ReplayTrajectory.from_config(cfg, rig, T0, scene=FlatScene())
    T = tr.states(T0 + (body.t_ns - body.t_ns[0])).T_w_b
    assert np.abs(T[0, :3, 3] - [3.0, 4.0, 0.25]).max() < 1e-6
    x0 = body.T[0, :3, 0]
    assert np.abs(T[0, 2, :3] - body.T[0, 2, :3]).max() < 1e-6   # tilt as the original (only turned about z)
    heading = np.arctan2(T[0, 1, 0], T[0, 0, 0])
    assert abs(heading - np.pi / 2) < 1e-6 and abs(np.hypot(*x0[:2]) - np.hypot(*T[0, :2, 0])) < 1e-9
    rel = np.linalg.inv(T[0]) @ T[-1]
    rel_in = np.linalg.inv(body.T[0]) @ body.T[-1]
    assert np.abs(rel - rel_in).max() < 1e-6


def test_kitti_without_times_names_the_option(tmp_path):
    path = tmp_path / "poses" / "00.txt"
    path.parent.mkdir()
    write_kitti(path, helix(duration_s=2.0))
    with pytest.raises(SimError, match=r"replay\.file: .*00\.txt: KITTI poses hold no timestamps.*--motion-times FILE"):
        ReplayTrajectory.from_config(ReplayConfig(file=str(path)), rig_of("cart27"), T0)
