"""Support for the rendering tests: a tiny scene and rigs built directly from rigs.model.

The scene does not depend on scenes/campus or scenes/indoor. Lighting is Lambertian (material
specular 0, shininess 0, no headlight, one directional light + ambient), so a surface point has
the same colour from every viewpoint: the premise of the photometric-consistency test.
"""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from rigs.model import Camera, Rig  # noqa: E402
from scenes.base import Route, Scene, SceneConfig  # noqa: E402
from rigs.geometry import make_T, rot_x, rot_y, rot_z  # noqa: E402

R_B_C_FORWARD = np.array([[0.0, 0, 1], [-1, 0, 0], [0, -1, 0]])


def noise_texture(rng: np.random.Generator, size: int = 256) -> np.ndarray:
    """(size, size, 3) uint8 smooth coloured noise: sum of bicubic random-lattice octaves."""
    img = np.zeros((size, size))
    for cells, amp in ((4, 1.0), (8, 0.6), (16, 0.4), (32, 0.3), (64, 0.2)):
        lattice = rng.random((cells, cells)).astype(np.float32)
        img += amp * cv2.resize(lattice, (size, size), interpolation=cv2.INTER_CUBIC)
    img = (img - img.min()) / np.ptp(img)
    rgb = np.stack([0.2 + 0.7 * img, 0.25 + 0.6 * img, 0.2 + 0.5 * img[::-1]], axis=2)
    return (255 * rgb).astype(np.uint8)


class RenderTestScene(Scene):
    """Ground plane (z=0), a wall facing -x at ``wall_x``, and spherical markers.

    ``markers``: tuple of ``(name, (x, y, z), radius)``; markers are white and emissive (their
    colour does not depend on light). ``ground``/``wall`` textured with seeded noise; ``sky`` adds
    a gradient skybox.
    """

    name = "render_test"

    def __init__(self, config=SceneConfig(name="render_test"), ground=True, wall_x=10.0,
                 markers=(), lit=True, sky=False):
        super().__init__(config)
        self.ground, self.wall_x, self.markers, self.lit = ground, wall_x, tuple(markers), lit
        self.sky = sky

    @property
    def route(self):
        return Route(((0.0, 0.0), (8.0, 0.0)))

    @property
    def gcp_sites(self):
        return ()

    def add_to_spec(self, spec, textures=None) -> None:
        spec.visual.headlight.active = 0
        rng = np.random.default_rng(self.config.seed)
        tex = spec.add_texture(name="noise", type=mujoco.mjtTexture.mjTEXTURE_2D, width=256, height=256,
                               nchannel=3)
        tex.data = noise_texture(rng).tobytes()
        mat = spec.add_material(name="noise", specular=0.0, shininess=0.0, texrepeat=[1, 1])
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "noise"
        mat.texuniform = True
        spec.add_material(name="marker", rgba=[1, 1, 1, 1], emission=1.0, specular=0.0, shininess=0.0)
        if self.sky:
            spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                             builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, width=64, height=64,
                             rgb1=[0.5, 0.7, 0.9], rgb2=[0.9, 0.9, 0.9])
        wb = spec.worldbody
        if self.lit:
            wb.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0, 0, 50],
                         dir=[0.3, 0.2, -1.0], diffuse=[0.7, 0.7, 0.7], ambient=[0.3, 0.3, 0.3],
                         specular=[0, 0, 0], castshadow=True)
        if self.ground:
            wb.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[60, 60, 1],
                        material="noise")
        if self.wall_x is not None:
            # Plane facing -x (its local +z -> world -x: rotation of -90 deg about y).
            wb.add_geom(name="wall", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[10, 30, 1],
                        pos=[self.wall_x, 0, 10], quat=[np.sqrt(0.5), 0, -np.sqrt(0.5), 0],
                        material="noise")
        for name, pos, radius in self.markers:
            wb.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0],
                        pos=[float(v) for v in pos], material="marker", contype=0, conaffinity=0)


def stereo_rig(width=160, height=120, fx=150.0, fy=130.0, dcx=23.3, dcy=-17.1,
               dist=(0, 0, 0, 0, 0), baseline=0.3, height_m=1.2, tilt=True) -> Rig:
    """Stereo rig with fx != fy, off-centre principal point and non-trivial rotations."""
    cams = []
    for k, y in enumerate((baseline / 2, -baseline / 2)):
        R_b_c = R_B_C_FORWARD
        if tilt:   # pitch down 4 deg, yaw +-2 deg, roll 1.5 deg (in the camera frame)
            R_b_c = rot_z(np.deg2rad(2.0 - 4.0 * k)) @ R_b_c @ rot_x(np.deg2rad(-4.0)) @ rot_z(np.deg2rad(1.5))
        cams.append(Camera(f"cam{k}", width, height, fx, fy, width / 2 + dcx, height / 2 + dcy,
                           dist=dist, T_b_c=make_T(R_b_c, [0.05, y, height_m])))
    return Rig("render_test", tuple(cams))


def vehicle_pose(x=0.0, y=0.0, yaw=0.0) -> np.ndarray:
    """(4,4) T_w_b on the ground plane."""
    return make_T(rot_z(yaw), [x, y, 0.0])


def test_world_places_cameras_exactly():
    """MuJoCo's camera pose (via mjcam) equals T_w_b @ T_b_c to float precision."""
    from sim.world import build_world
    rig = stereo_rig()
    world = build_world(RenderTestScene(), rig)
    T_w_b = make_T(rot_z(0.7) @ rot_y(0.05), [1.0, -2.0, 0.3])
    world.set_vehicle_pose(T_w_b)
    for k, cam in enumerate(rig.cameras):
        # MuJoCo stores quaternions normalised in float64: agreement to ~1e-12.
        np.testing.assert_allclose(world.T_w_c(k), T_w_b @ cam.T_b_c_array, atol=1e-9)
