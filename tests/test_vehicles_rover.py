"""The rover and its pan-tilt mast: the mast model reproduces the rig, follows CONVENTIONS.md, and a
point rendered at a known pan/tilt lands at its predicted pixel."""
import numpy as np
import pytest

from rigs.presets import get_rig
from sim.vehicles import vehicle_class
from sim.vehicles.rover import ROVER, MastHead
from vo.crosssite.types import mast_T_b_c


@pytest.fixture(scope="module")
def rig():
    return get_rig("yutu-navcam")


def test_rover_size_and_registration():
    assert vehicle_class("rover").dims is ROVER
    assert ROVER.wheelbase_m == 1.0 and ROVER.track_m == pytest.approx(1.16)


def test_mast_reproduces_the_rig_at_pan_0(rig):
    head = MastHead.from_rig(rig)
    assert head.tilt0_rad == pytest.approx(np.radians(20.0), abs=1e-12)
    assert head.T_b_mast[:3, 3] == pytest.approx([0.3, 0.0, 1.5])
    for k, cam in enumerate(rig.cameras):
        assert np.allclose(head.T_b_c(k, 0.0, head.tilt0_rad), cam.T_b_c_array, atol=1e-12)


def test_mast_follows_the_conventions(rig):
    head = MastHead.from_rig(rig)
    pan, tilt = np.radians(35.0), np.radians(27.0)
    T = head.T_b_c(0, pan, tilt)
    assert np.allclose(T, mast_T_b_c(head.T_b_mast, pan, tilt, head.T_head_c[0]), atol=1e-12)
    z = T[:3, 2]                                                   # optical axis: left by pan, down by tilt
    assert np.degrees(np.arctan2(z[1], z[0])) == pytest.approx(35.0)
    assert np.degrees(np.arcsin(-z[2])) == pytest.approx(27.0)
    # the stereo baseline is rigid under pan and tilt
    assert np.allclose(np.linalg.inv(T) @ head.T_b_c(1, pan, tilt), np.linalg.inv(rig.cameras[0].T_b_c_array)
                       @ rig.cameras[1].T_b_c_array, atol=1e-12)


def test_point_at_known_pan_tilt_lands_at_predicted_pixel(rig):
    """An emissive red sphere (r = 2 cm) 3 m in front of the mast, pointing pan 40 deg / tilt 25 deg: the centroid of
    its red pixels in both images is the projection of its centre within 0.5 px (the perspective
    centroid bias of so small a sphere is < 0.01 px)."""
    import mujoco
    from rigs.geometry import make_T, rot_z
    from scenes.base import SceneConfig
    from scenes.registry import make_scene
    from sim.render import StereoRenderer
    from sim.rng import scene_streams
    from sim.world import build_world
    scene = make_scene(SceneConfig(name="lunar", seed=0, shadows=False), scene_streams(0))
    head = MastHead.from_rig(rig)
    xy = scene.sites_xy[2]
    T_w_b = make_T(rot_z(-1.2), np.r_[xy, scene.ground_height(*xy)])
    pan, tilt = np.radians(40.0), np.radians(25.0)
    T_w_c = [T_w_b @ head.T_b_c(k, pan, tilt) for k in range(2)]
    p_c0 = np.array([0.15, -0.6, 3.0])
    p_w = T_w_c[0][:3, :3] @ p_c0 + T_w_c[0][:3, 3]

    def marker(spec):
        spec.add_material(name="marker", rgba=[1, 0, 0, 1], emission=1.0, specular=0.0)
        spec.worldbody.add_geom(name="static/marker", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.02, 0, 0],
                                pos=p_w.tolist(), material="marker", contype=0, conaffinity=0)
    world = build_world(scene, rig, vehicle="rover", extra=marker)
    head.set_pointing(world, pan, tilt)
    with StereoRenderer(world, rig) as r:
        images = r.render(T_w_b).images
    for k, img in enumerate(images):
        red = (img[..., 0].astype(int) - img[..., 1] > 60) & (img[..., 2] < 60)
        v, u = np.nonzero(red)
        assert red.sum() > 20
        q = np.linalg.inv(T_w_c[k]) @ np.r_[p_w, 1.0]
        uv = (rig.cameras[k].K @ (q[:3] / q[2]))[:2]
        assert np.hypot(u.mean() - uv[0], v.mean() - uv[1]) < 0.5
