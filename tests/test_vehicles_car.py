"""The ``car`` vehicle: registration, geometry from the rig, the cameras do not see it, and its urban drive
(speed 0-12 m/s, a stop at the intersection, a right turn)."""
import numpy as np
import pytest

from rigs.presets import get_rig
from scenes import SceneConfig, make_scene
from sim.motion import MotionConfig, VehicleTrajectory
from sim.rng import scene_streams, stream
from sim.vehicles import CAR, VEHICLES, vehicle_class
from sim.vehicles.car import HOOD_AHEAD_M, HOOD_TOP_M


def urban_trajectory(seed=0):
    sc = make_scene(SceneConfig(name="urban", dynamic_density=0.0), scene_streams(seed), stream(seed, "dynamic"))
    cfg = MotionConfig(wheelbase_m=CAR.wheelbase_m, track_m=CAR.track_m)
    return sc, VehicleTrajectory.from_route(sc.route, sc.ground_height, cfg, stream(seed, "motion"))


def test_car_registered_with_its_running_gear():
    assert vehicle_class("car") is VEHICLES["car"]
    assert (CAR.track_m, CAR.wheelbase_m, CAR.wheel_radius_m) == (1.55, 2.7, 0.32)


@pytest.mark.parametrize("rig_name", ["paper002", "kitti-like"])
def test_car_geometry_below_and_behind_the_view(rig_name):
    """Every car geom's corner lies outside the cameras' view: below the lower image edge's plane or behind."""
    import mujoco
    rig = get_rig(rig_name)
    spec = mujoco.MjSpec()
    vehicle_class("car")(rig).add_to(spec)
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    for cam in rig.cameras:
        T_b_c = cam.T_b_c_array
        half_v = np.arctan((cam.height - 1 - cam.cy) / cam.fy)          # lower half field of view
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
                corners = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * m.geom_size[g]
                p_b = corners @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
            else:                                                         # cylinders: bounding box
                r, h = m.geom_size[g][:2]
                p_b = d.geom_xpos[g] + np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * max(r, h)
            p_c = (p_b - T_b_c[:3, 3]) @ T_b_c[:3, :3]
            ahead = p_c[:, 2] > 1e-6
            below = np.arctan2(p_c[ahead, 1], p_c[ahead, 2]) > half_v
            assert np.all(below), f"{rig_name} {cam.name}: geom {name} reaches into the view"
    # wheels stand on the ground (body origin at ground level), the hood is where the docstring says
    wheel = [g for g in range(m.ngeom) if "wheel" in mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)]
    assert len(wheel) == 4
    for g in wheel:
        assert d.geom_xpos[g][2] == pytest.approx(CAR.wheel_radius_m, abs=1e-12)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "vehicle/body")
    x_front = max(c.T_b_c_array[0, 3] for c in rig.cameras)
    assert d.geom_xpos[body][0] + m.geom_size[body][0] == pytest.approx(x_front + HOOD_AHEAD_M, abs=1e-9)
    assert d.geom_xpos[body][2] + m.geom_size[body][2] == pytest.approx(HOOD_TOP_M, abs=1e-9)


def test_urban_drive_speeds_stop_and_turn():
    sc, tr = urban_trajectory()
    t = np.arange(tr.t0_ns, tr.t1_ns + 1, 10_000_000)
    st = tr.states(t)
    speed = np.linalg.norm(st.v_w, axis=1)
    # cruise 10 m/s; the vibration's heave (3 mm RSS at <= 2.4 Hz) adds at most 2 pi 2.4 0.003 = 0.045 m/s
    assert speed.max() <= 12.0 and speed.max() == pytest.approx(10.0, abs=0.045)
    # at rest at the stop line (x = -19) for the dwell time (4 s), then the right turn
    rest = (speed < 1e-9) & (t > tr.t0_ns + 5e9) & (t < tr.t1_ns - 5e9)
    # the dwell plus the ramp ends where v = 10 * 35 tau^4 < 1e-9 m/s (tau < 1.3e-3 of 14.6 s: 19 ms each)
    assert 4.0 <= rest.sum() * 0.01 <= 4.0 + 2 * 0.019 + 0.01
    np.testing.assert_allclose(st.T_w_b[rest][:, :2, 3], [[-19.0, -5.25]] * rest.sum(), atol=0.01)
    yaw = np.unwrap(np.arctan2(st.T_w_b[:, 1, 0], st.T_w_b[:, 0, 0]))
    assert yaw[0] == pytest.approx(0.0, abs=0.01) and yaw[-1] == pytest.approx(-np.pi / 2, abs=0.01)
    # lateral acceleration in the 9 m turn, entered 4.75 m after the stop: a brisk turn (5.3 m/s^2 at 6.7 m/s,
    # plus the vibration), within what a car's tyres give on dry asphalt (~8 m/s^2)
    a_lat = np.abs(st.v_w[:, 0] * st.a_w[:, 1] - st.v_w[:, 1] * st.a_w[:, 0]) / np.maximum(speed, 1e-9)
    assert a_lat.max() < 6.0
    # speed continuous at the leg joints: largest step between 10 ms samples below what 3 m/s^2 allows
    assert np.abs(np.diff(speed)).max() < 0.03


def test_stop_go_profile_matches_its_derivatives():
    """s' and s'' of the stop-and-go profile agree with central differences of s (exactness of the legs)."""
    _, tr = urban_trajectory()
    pr = tr.profile
    t = np.linspace(0.5, pr.duration - 0.5, 4001)
    h = 1e-4
    s0 = pr(t)
    sp, sm = pr(t + h)[0], pr(t - h)[0]
    np.testing.assert_allclose((sp - sm) / (2 * h), s0[1], atol=1e-6)      # O(h^2 s''') ~ 1e-8
    spd, smd = pr(t + h)[1], pr(t - h)[1]
    np.testing.assert_allclose((spd - smd) / (2 * h), s0[2], atol=1e-5)
    assert pr(np.array([pr.duration + 1.0]))[0][0] == pytest.approx(pr.length_m, abs=1e-9)
