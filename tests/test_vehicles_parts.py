"""Vehicles as parts: each adds its named subtree to a fresh MjSpec and returns handles that compile;
its running gear (one VehicleDims) is what the MJCF wheels, the motion defaults and the odometry use."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from rigs.presets import get_rig  # noqa: E402
from sim.errors import SimError  # noqa: E402
from sim.motion import MotionConfig  # noqa: E402
from sim.vehicles import CART, VEHICLE_GROUP, VEHICLES, VehicleDims, make_vehicle  # noqa: E402

RIG = get_rig("cart27")


@pytest.mark.parametrize("kind", sorted(VEHICLES))
def test_vehicle_adds_its_named_subtree_and_handles_resolve(kind):
    spec = mujoco.MjSpec()
    h = make_vehicle(kind, RIG).add_to(spec)
    m = spec.compile()
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, h.body)
    assert body > 0 and m.body_mocapid[body] == 0 and h.kind == kind
    cams = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, n) for n in h.camera_names]
    assert len(cams) == len(RIG.cameras) and min(cams) >= 0 and all(m.cam_bodyid[c] == body for c in cams)
    assert m.site_bodyid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, h.imu_site)] == body
    names = [m.geom(i).name for i in range(m.ngeom)]
    assert names and all(n.startswith("vehicle/") for n in names)             # its own name scope
    assert np.all(m.geom_group == VEHICLE_GROUP) and not np.any(m.geom_contype | m.geom_conaffinity)


@pytest.mark.parametrize("kind", sorted(k for k, c in VEHICLES.items() if c.dims is not None))
def test_mjcf_wheels_are_the_vehicle_dims(kind):
    """Wheel geoms: radius = dims.wheel_radius_m, centres at +-track/2 and spread over the wheelbase."""
    v = make_vehicle(kind, RIG)
    spec = mujoco.MjSpec()
    v.add_to(spec)
    m = spec.compile()
    wheels = [i for i in range(m.ngeom) if m.geom(i).name.startswith("vehicle/wheel")]
    pos = m.geom_pos[wheels]
    np.testing.assert_allclose(m.geom_size[wheels, 0], v.dims.wheel_radius_m)
    np.testing.assert_allclose(np.abs(pos[:, 1]), v.dims.track_m / 2)
    np.testing.assert_allclose(np.ptp(pos[:, 0]), v.dims.wheelbase_m)
    np.testing.assert_allclose(pos[:, 2], v.dims.wheel_radius_m)            # wheels touch the ground


def test_two_vehicles_keep_their_own_name_scopes():
    spec = mujoco.MjSpec()
    ego = make_vehicle("cart", RIG).add_to(spec)
    other = make_vehicle("rover", RIG, name="rover1").add_to(spec)
    m = spec.compile()
    assert ego.body == "vehicle" and other.body == "rover1" and other.imu_site == "rover1/imu"
    owner = {m.geom(i).name.split("/")[0]: m.geom_bodyid[i] for i in range(m.ngeom)}
    assert owner["vehicle"] != owner["rover1"] and m.ncam == 2 * len(RIG.cameras)
    with pytest.raises(SimError, match="vehicle name"):
        make_vehicle("cart", RIG, name="a/b")


def test_motion_defaults_are_the_carts():
    assert MotionConfig().track_m == CART.track_m and MotionConfig().wheelbase_m == CART.wheelbase_m


def test_bad_kind_and_bad_dims_are_one_line_errors():
    with pytest.raises(SimError, match=r"unknown kind 'bike'; valid: cart, rover"):
        make_vehicle("bike", RIG)
    with pytest.raises(SimError, match=r"dims\.track_m"):
        VehicleDims(track_m=-1.0, wheelbase_m=0.6, wheel_radius_m=0.1)
