"""VehicleTrajectory: smoothness and exact derivatives, route geometry, speed profile, terrain."""
import numpy as np
import pytest

from scenes.base import Route
from sim.errors import SimError
from sim.rng import stream
from sim.motion import MotionConfig, VehicleTrajectory

STILL = MotionConfig(vibration_pitch_deg=0, vibration_roll_deg=0, vibration_yaw_deg=0, vibration_heave_m=0)
LOOP = Route(((0, 0), (6, -1), (10, 0), (11, 4), (6, 6), (0, 5), (-2, 2)), closed=True,
             cruise_speed_mps=1.0, accel_mps2=0.4)


def hills(x, y):
    return 0.2 * np.sin(0.3 * x) + 0.1 * np.cos(0.4 * y) + 0.02 * x


def circle_route(radius=5.0, n=24, speed=1.2):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return Route(tuple(zip(radius * np.cos(a), radius * np.sin(a))), closed=True, cruise_speed_mps=speed)


def flat(x, y):
    return np.zeros(np.broadcast(np.asarray(x), np.asarray(y)).shape)


def d5(f, t_ns, h_ns):
    """5-point central derivative of f (array-valued) at t_ns with step h: error h^4/30 |f^(5)|."""
    h = h_ns * 1e-9
    fm2, fm1, fp1, fp2 = (f(t_ns + k * h_ns) for k in (-2, -1, 1, 2))
    return (fm2 - 8 * fm1 + 8 * fp1 - fp2) / (12 * h)


@pytest.fixture(scope="module")
def loop():
    return VehicleTrajectory.from_route(LOOP, hills, MotionConfig(), stream(3, "motion"))


def _probe_times(tr, n=40, seed=0):
    rng = np.random.default_rng(seed)
    pr = tr.profile
    edges = tr.t0_ns + np.round(np.array([pr.t_ramp, pr.t_ramp + pr.t_cruise]) * 1e9).astype(np.int64)
    rand = rng.integers(tr.t0_ns + 10**7, tr.t1_ns - 10**7, size=n)
    return np.sort(np.r_[rand, edges, edges + 1234567])


def test_velocity_and_acceleration_are_derivatives(loop):
    """h = 1 ms: truncation h^4/30 |f^(5)| < 1e-10 for <= 2.5 Hz vibration and metre-scale paths;
    rounding ~ 1e-16 * 20 m / 1e-3 s = 2e-12. The 1e-7 tolerance leaves room for the C4 knots."""
    t = _probe_times(loop)
    st = loop.states(t)
    v_fd = d5(lambda tt: loop.states(tt).T_w_b[:, :3, 3], t, 10**6)
    a_fd = d5(lambda tt: loop.states(tt).v_w, t, 10**6)
    assert np.abs(v_fd - st.v_w).max() < 1e-7
    assert np.abs(a_fd - st.a_w).max() < 1e-7
    assert np.abs(st.v_w).max() > 0.5 and np.abs(st.a_w).max() > 0.05     # non-trivial motion


def test_angular_rate_and_acceleration_are_derivatives(loop):
    """omega_b from R^T dR/dt (5-point) and alpha_b from d omega_b / dt; same error budget as above."""
    t = _probe_times(loop, seed=1)
    st = loop.states(t)
    R_dot = d5(lambda tt: loop.states(tt).T_w_b[:, :3, :3], t, 10**6)
    W = np.einsum("nji,njk->nik", st.T_w_b[:, :3, :3], R_dot)
    om_fd = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
    al_fd = d5(lambda tt: loop.states(tt).omega_b, t, 10**6)
    assert np.abs(om_fd - st.omega_b).max() < 1e-7
    assert np.abs(al_fd - st.alpha_b).max() < 1e-7
    assert np.all(np.abs(st.omega_b).max(axis=0) > 1e-3)                # excited on all three axes


def test_closed_route_ends_at_rest_where_it_starts(loop):
    st = loop.states(np.array([loop.t0_ns, loop.t1_ns]))
    assert np.allclose(st.T_w_b[0], st.T_w_b[1], atol=1e-12)
    assert np.abs(st.v_w).max() < 1e-12 and np.abs(st.a_w).max() < 1e-12
    assert np.abs(st.omega_b).max() < 1e-12 and np.abs(st.alpha_b).max() < 1e-12


def test_circle_length_speed_and_pass_times():
    """24 waypoints on a 5 m circle: the quintic interpolant's length equals 2 pi r to < 1e-5
    relative (interpolation error ~ (h/r)^6 with h/r = 0.26); cruise speed exact to 1e-6 (arc-length
    re-sampling at 0.1 m)."""
    tr = VehicleTrajectory.from_route(circle_route(), flat, STILL, stream(0, "motion"))
    assert tr.route_length_m == pytest.approx(2 * np.pi * 5.0, rel=1e-5)
    assert tr.path_length() == pytest.approx(tr.route_length_m, rel=1e-6)
    pr = tr.profile
    t_cruise = tr.t0_ns + np.round(np.linspace(pr.t_ramp, pr.t_ramp + pr.t_cruise, 50) * 1e9).astype(np.int64)
    assert np.abs(np.linalg.norm(tr.states(t_cruise).v_w, axis=1) - 1.2).max() < 1e-6
    ang = np.array([0.5, 2.0, 4.0])
    pts = 7.0 * np.column_stack([np.cos(ang), np.sin(ang)])              # outside the circle
    xy = tr.states(tr.pass_times_ns(pts)).T_w_b[:, :2, 3]
    assert np.abs(xy - 5.0 * np.column_stack([np.cos(ang), np.sin(ang)])).max() < 1e-3  # 1 ms at 1.2 m/s


def test_open_route_straight_line_speed_profile():
    """Straight 20 m: ends at the far waypoint at rest; peak acceleration = route.accel_mps2; the
    heading is +x throughout; duration = L/v + t_ramp (two ramps each cover v t_ramp / 2)."""
    route = Route(((0, 0), (20, 0)), cruise_speed_mps=1.5, accel_mps2=0.5)
    tr = VehicleTrajectory.from_route(route, flat, STILL, stream(0, "motion"))
    t = np.linspace(tr.t0_ns, tr.t1_ns, 4001).astype(np.int64)
    st = tr.states(t)
    assert np.allclose(st.T_w_b[-1, :3, 3], [20, 0, 0], atol=1e-9)
    assert np.abs(st.v_w[[0, -1]]).max() < 1e-12
    assert np.abs(st.a_w[:, 0]).max() == pytest.approx(0.5, rel=1e-3)    # 4001 samples resolve the peak
    assert np.allclose(st.T_w_b[:, :3, 0], [1, 0, 0], atol=1e-9)
    assert (tr.t1_ns - tr.t0_ns) * 1e-9 == pytest.approx(20 / 1.5 + tr.profile.t_ramp, abs=1e-9)


def test_short_route_lowers_peak_speed():
    route = Route(((0, 0), (1, 0)), cruise_speed_mps=2.0, accel_mps2=0.5)
    tr = VehicleTrajectory.from_route(route, flat, STILL, stream(0, "motion"))
    st = tr.states(np.linspace(tr.t0_ns, tr.t1_ns, 2001).astype(np.int64))
    assert np.linalg.norm(st.v_w, axis=1).max() < 2.0
    assert np.abs(st.a_w[:, 0]).max() == pytest.approx(0.5, rel=1e-3)
    assert np.allclose(st.T_w_b[-1, :3, 3], [1, 0, 0], atol=1e-9)


def test_body_lies_on_a_sloped_plane():
    """On z = 0.1 x + 0.05 y the spline reproduces the plane exactly: origin on it, body z = normal."""
    plane = lambda x, y: 0.1 * np.asarray(x) + 0.05 * np.asarray(y)
    tr = VehicleTrajectory.from_route(LOOP, plane, STILL, stream(0, "motion"))
    st = tr.states(np.linspace(tr.t0_ns, tr.t1_ns, 300).astype(np.int64))
    p = st.T_w_b[:, :3, 3]
    assert np.abs(p[:, 2] - plane(p[:, 0], p[:, 1])).max() < 1e-9
    n = np.array([-0.1, -0.05, 1.0]) / np.linalg.norm([-0.1, -0.05, 1.0])
    # 1e-8: yaw comes from the re-fitted x(s), y(s), the slope probes from the chord spline's
    # tangent; the two differ by the 0.1 m re-sampling error (measured 4e-9 rad)
    assert np.abs(st.T_w_b[:, :3, 2] - n).max() < 1e-8


def test_vibration_is_seeded_and_bounded():
    a = VehicleTrajectory.from_route(LOOP, flat, MotionConfig(), stream(1, "motion"))
    b = VehicleTrajectory.from_route(LOOP, flat, MotionConfig(), stream(1, "motion"))
    c = VehicleTrajectory.from_route(LOOP, flat, MotionConfig(), stream(2, "motion"))
    t = np.linspace(a.t0_ns, a.t1_ns, 500).astype(np.int64)
    Ta, Tb, Tc = (x.states(t).T_w_b for x in (a, b, c))
    assert Ta.tobytes() == Tb.tobytes()
    assert np.abs(Ta - Tc).max() > 1e-4
    # heave amplitude: root-sum-square 3 mm, so |z| <= sum of amplitudes <= 3 mm * sqrt(3)
    assert 1e-3 < np.abs(Ta[:, 2, 3]).max() <= 0.003 * np.sqrt(3) + 1e-12


def test_duration_truncates_only():
    full = VehicleTrajectory.from_route(LOOP, hills, MotionConfig(), stream(5, "motion"))
    cut = VehicleTrajectory.from_route(LOOP, hills, MotionConfig(), stream(5, "motion"), duration_s=10.0)
    assert cut.t1_ns - cut.t0_ns == 10 * 10**9
    t = np.linspace(cut.t0_ns, cut.t1_ns, 50).astype(np.int64)
    assert full.states(t).T_w_b.tobytes() == cut.states(t).T_w_b.tobytes()


def test_cruise_speed_override_replaces_the_routes():
    """``motion.cruise_speed_mps`` replaces the route's cruise speed on the same path: the peak speed is the
    override, the duration is L/v + t_ramp at the new speed, and the path (pose against arc length) is the same;
    0 keeps the route's speed exactly."""
    route = Route(((0, 0), (100, 0)), cruise_speed_mps=1.5, accel_mps2=0.5)
    base = VehicleTrajectory.from_route(route, flat, STILL, stream(0, "motion"))
    same = VehicleTrajectory.from_route(route, flat, MotionConfig(**{**STILL.__dict__, "cruise_speed_mps": 0.0}),
                                        stream(0, "motion"))
    fast = VehicleTrajectory.from_route(route, flat, MotionConfig(**{**STILL.__dict__, "cruise_speed_mps": 3.0}),
                                        stream(0, "motion"))
    t = np.linspace(base.t0_ns, base.t1_ns, 501).astype(np.int64)
    assert same.states(t).T_w_b.tobytes() == base.states(t).T_w_b.tobytes()
    tf = np.linspace(fast.t0_ns, fast.t1_ns, 4001).astype(np.int64)
    st = fast.states(tf)
    assert np.linalg.norm(st.v_w, axis=1).max() == pytest.approx(3.0, rel=1e-9)
    assert (fast.t1_ns - fast.t0_ns) * 1e-9 == pytest.approx(100 / 3.0 + fast.profile.t_ramp, abs=1e-9)
    assert fast.profile.t_ramp == pytest.approx(2 * base.profile.t_ramp, rel=1e-12)   # ramp time v / a scale
    assert np.allclose(st.T_w_b[-1, :3, 3], [100, 0, 0], atol=1e-9)


@pytest.mark.parametrize("field,value", [("vibration_pitch_deg", -1.0), ("path_sample_m", 0.0),
                                         ("vibration_freqs_hz", ()), ("start_time_ns", -5),
                                         ("cruise_speed_mps", -1.0), ("cruise_speed_mps", 100.0)])
def test_config_validation_names_the_field(field, value):
    with pytest.raises(SimError, match=field):
        MotionConfig(**{field: value})


def test_corner_smoothing_keeps_straights_and_ends():
    """Open L-shaped polyline with sigma = 1 m: end points fixed (point-reflection padding), the
    middle of each long straight exactly on the polyline (Gaussian of a line is the line: < 1e-6 m
    after spline fitting), no overshoot beyond the polyline's bounding box."""
    route = Route(((0, 0), (10, 0), (10, 5), (30, 5)))
    tr = VehicleTrajectory.from_route(route, flat, MotionConfig(corner_smoothing_m=1.0), stream(0, "motion"))
    st = tr.states(np.linspace(tr.t0_ns, tr.t1_ns, 3000).astype(np.int64))
    p = st.T_w_b[:, :3, 3]
    assert np.allclose(p[[0, -1], :2], [[0, 0], [30, 5]], atol=1e-9)
    assert p[:, 0].min() > -1e-6 and p[:, 0].max() < 30 + 1e-6 and p[:, 1].min() > -1e-6 and p[:, 1].max() < 5 + 1e-6
    on_first = (p[:, 0] > 2) & (p[:, 0] < 6)
    assert on_first.sum() > 50 and np.abs(p[on_first, 1]).max() < 1e-6


def test_rest_periods_shift_the_motion():
    """rest_before_s = 2: standing still (exactly) for 2 s, then the same motion shifted by 2 s."""
    base = VehicleTrajectory.from_route(LOOP, hills, MotionConfig(), stream(4, "motion"))
    rest = VehicleTrajectory.from_route(LOOP, hills, MotionConfig(rest_before_s=2.0, rest_after_s=1.0),
                                        stream(4, "motion"))
    assert rest.t1_ns - rest.t0_ns == base.t1_ns - base.t0_ns + 3 * 10**9
    still = rest.states(np.linspace(rest.t0_ns, rest.t0_ns + 2 * 10**9, 20).astype(np.int64))
    assert np.abs(still.v_w).max() == 0 and np.abs(still.omega_b).max() == 0
    t = np.linspace(base.t0_ns, base.t1_ns, 30).astype(np.int64)
    # vibration phases are in absolute time, so compare the vibration-free part: x, y
    assert np.allclose(rest.states(t + 2 * 10**9).T_w_b[:, :2, 3], base.states(t).T_w_b[:, :2, 3], atol=1e-9)
    traj = rest.to_trajectory(t)
    assert traj.T.shape == (30, 4, 4) and traj.frame == "b"
