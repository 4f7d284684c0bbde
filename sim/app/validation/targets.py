"""A scene of fronto-parallel, richly textured target boards for stereo range-error validation.

Layout (exact by construction): the vehicle stands at the world origin; for range ``r_k`` it is
yawed to ``psi_k = k * spacing`` and one board is placed with its front face *perpendicular to the
left camera's optical axis* at exactly ``r_k`` along that axis, centred on it. So in frame ``k``
the target board fills the image centre at constant depth ``Z = r_k`` (OpenCV ``z`` of ``c0``), and
boards of other ranges lie at other azimuths, at least ``spacing - 2 * half_width`` degrees away,
which keeps them out of the target board's line of sight from both cameras (the cameras sit within
~0.6 m of the vehicle origin, <= 17 deg of parallax at 2 m).

Every board subtends the same angle (``half_angles_deg``), so its texture lands on the image with
the same pixel scale at every range: the disparity error of a matcher should not depend on range,
which is the assumption behind seed 001 eq. 7. Boards reach below the ground at long range; the
ground hides their lower part identically in both cameras (same depth, cameras at the same height).
Board geoms are named ``static/board/<k>``.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

os.environ.setdefault("MUJOCO_GL", "egl")  # before the first mujoco import (headless)

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np

from rigs.geometry import quat_wxyz_from_R
from scenes.base import Route, Scene, SceneConfig
from scenes.errors import SceneError
from scenes.textures import make_texture
from sim.rng import scene_streams

BOARD_PREFIX = "static/board/"


@dataclass(frozen=True)
class Board:
    """One target board. Board frame: x = face normal pointing away from the viewer, y left, z up.

    ``center_w`` (3,) centre of the *front* face in world; ``R_w_board`` 3x3 nested tuple;
    ``half_w``, ``half_h`` half sizes of the face (m); ``thickness`` (m, extends along +x);
    ``tex_seed`` seeds the board's texture; ``tex_size`` texels per side (power of two).
    """

    name: str
    center_w: tuple
    R_w_board: tuple
    half_w: float
    half_h: float
    thickness: float = 0.02
    tex_seed: int = 0
    tex_size: int = 128

    def __post_init__(self):
        if np.asarray(self.center_w, float).shape != (3,):
            raise SceneError(f"board {self.name!r}.center_w: expected 3 numbers, got {self.center_w!r}")
        R = np.asarray(self.R_w_board, float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
            raise SceneError(f"board {self.name!r}.R_w_board: expected an orthonormal 3x3 rotation")
        for f in ("half_w", "half_h", "thickness"):
            if not float(getattr(self, f)) > 0:
                raise SceneError(f"board {self.name!r}.{f}: must be > 0, got {getattr(self, f)!r}")
        if self.tex_size < 16 or self.tex_size & (self.tex_size - 1):
            raise SceneError(f"board {self.name!r}.tex_size: must be a power of two >= 16, got {self.tex_size!r}")

    def face_corners_w(self) -> np.ndarray:
        """(4,3) world corners of the front face: top-left, top-right, bottom-right, bottom-left
        as seen from the viewer (board +y is the viewer's left)."""
        R, c = np.asarray(self.R_w_board, float), np.asarray(self.center_w, float)
        local = np.array([[0, self.half_w, self.half_h], [0, -self.half_w, self.half_h],
                          [0, -self.half_w, -self.half_h], [0, self.half_w, -self.half_h]])
        return local @ R.T + c


def board_texture(seed: int, size: int = 128) -> np.ndarray:
    """(size, size, 3) uint8 seeded, non-repetitive texture: multi-scale value noise (cells of 2..32
    texels, bicubic) plus ``size`` hard-edged grey rectangles (strong corners at every scale)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0xB0A2D]))
    g = np.zeros((size, size))
    for cells in (2, 4, 8, 16, 32):
        n = max(2, size // cells)
        g += cv2.resize(rng.random((n, n)), (size, size), interpolation=cv2.INTER_CUBIC) * (cells / 32) ** 0.3
    lo, hi = np.percentile(g, [2, 98])
    g = np.clip((g - lo) / max(hi - lo, 1e-9), 0, 1)
    for _ in range(size):
        h, w = rng.integers(2, max(3, size // 6), size=2)
        y, x = rng.integers(0, size - 1, size=2)
        g[y:y + h, x:x + w] = 0.3 * g[y:y + h, x:x + w] + 0.7 * rng.random()
    tint = 0.75 + 0.25 * rng.random(3)
    rgb = np.clip(0.08 + 0.84 * g[..., None] * tint[None, None, :], 0, 1)
    return np.round(rgb * 255).astype(np.uint8)


def _board_mesh(board: Board) -> tuple:
    """(vertices (24,3), texcoords (24,2), faces (12,3)) of a box in the board frame, relative to the
    front-face centre; the front face (x = 0) maps the texture once, image top = board +z."""
    hw, hh, t = board.half_w, board.half_h, board.thickness
    x = {0: 0.0, 1: t}
    verts, uvs, faces = [], [], []

    def quad(pts, uv, n_out):
        p = [np.asarray(q, float) for q in pts]
        order = [0, 1, 2, 3] if np.dot(np.cross(p[1] - p[0], p[2] - p[0]), n_out) > 0 else [0, 3, 2, 1]
        k = len(verts)
        verts.extend(p[i] for i in order)
        uvs.extend(uv[i] for i in order)
        faces.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]])

    # front face: viewer's left is board +y -> texture u = 0 at +y; texture v = 0 (top row) at +z
    quad([(0, hw, hh), (0, -hw, hh), (0, -hw, -hh), (0, hw, -hh)], [(0, 0), (1, 0), (1, 1), (0, 1)], (-1, 0, 0))
    z0 = [(0.0, 0.0)] * 4
    quad([(t, hw, hh), (t, -hw, hh), (t, -hw, -hh), (t, hw, -hh)], z0, (1, 0, 0))
    for s in (1, -1):
        quad([(x[0], s * hw, hh), (x[1], s * hw, hh), (x[1], s * hw, -hh), (x[0], s * hw, -hh)], z0, (0, s, 0))
        quad([(x[0], hw, s * hh), (x[1], hw, s * hh), (x[1], -hw, s * hh), (x[0], -hw, s * hh)], z0, (0, 0, s))
    return np.array(verts), np.array(uvs), np.array(faces)


class TargetScene(Scene):
    """Ground plane, soft uniform lighting and the given :class:`Board` s (see module docstring)."""

    name = "targets"

    def __init__(self, config: SceneConfig, boards: tuple):
        super().__init__(config)
        self.boards = tuple(boards)
        names = [b.name for b in self.boards]
        if len(set(names)) != len(names):
            raise SceneError(f"targets.boards: duplicate board names {names}")

    @property
    def route(self) -> Route:
        return Route(((0.0, 0.0), (1.0, 0.0)))

    @property
    def gcp_sites(self) -> tuple:
        return ()

    def extent_xy(self) -> tuple:
        c = np.array([b.center_w for b in self.boards] + [[0.0, 0.0, 0.0]])
        return (c[:, 0].min() - 5, c[:, 0].max() + 5, c[:, 1].min() - 5, c[:, 1].max() + 5)

    def add_to_spec(self, spec, textures=None) -> None:
        lit = float(self.config.lighting)
        spec.visual.headlight.ambient = [0.35 * lit] * 3
        spec.visual.headlight.diffuse = [0.45 * lit] * 3
        spec.visual.headlight.specular = [0.0] * 3
        spec.worldbody.add_light(name="static/sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0, 0, 50], dir=[0.3, 0.2, -1.0],
                                 diffuse=[0.35 * lit] * 3, specular=[0, 0, 0],
                                 castshadow=bool(self.config.shadows))
        self._add_ground(spec)
        for b in self.boards:
            self._add_board(spec, b)

    def _add_ground(self, spec) -> None:
        rng = scene_streams(self.config.seed)("texture/grass/0")
        img = make_texture("grass", rng, self.config.texture_richness, 256)
        self._texture(spec, "tex/ground", img)
        mat = spec.add_material(name="mat/ground", specular=0.0, shininess=0.0, texuniform=True,
                                texrepeat=[0.5, 0.5])
        self._bind(mat, "tex/ground")
        spec.worldbody.add_geom(name="static/ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[100, 100, 0.1],
                                material="mat/ground", contype=0, conaffinity=0)

    def _add_board(self, spec, b: Board) -> None:
        self._texture(spec, f"tex/board/{b.name}", board_texture(b.tex_seed, b.tex_size))
        mat = spec.add_material(name=f"mat/board/{b.name}", specular=0.0, shininess=0.0)
        self._bind(mat, f"tex/board/{b.name}")
        v, uv, f = _board_mesh(b)
        mesh = spec.add_mesh(name=f"mesh/board/{b.name}")
        mesh.uservert = v.ravel().tolist()
        mesh.usertexcoord = uv.ravel().tolist()
        mesh.userface = f.ravel().tolist()
        spec.worldbody.add_geom(name=BOARD_PREFIX + b.name, type=mujoco.mjtGeom.mjGEOM_MESH,
                                meshname=f"mesh/board/{b.name}", pos=list(map(float, b.center_w)),
                                quat=list(map(float, quat_wxyz_from_R(np.asarray(b.R_w_board, float)))),
                                material=f"mat/board/{b.name}", contype=0, conaffinity=0)

    @staticmethod
    def _texture(spec, name: str, img: np.ndarray) -> None:
        tex = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D,
                               width=img.shape[1], height=img.shape[0], nchannel=3)
        tex.data = img.tobytes()

    @staticmethod
    def _bind(mat, tex_name: str) -> None:
        tx = list(mat.textures)
        tx[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex_name
        mat.textures = tx


def yaw_T(psi: float) -> np.ndarray:
    """(4,4) ``T_w_b`` of the vehicle at the origin, yawed by ``psi`` (rad) about world z."""
    c, s = np.cos(psi), np.sin(psi)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def board_layout(rig, ranges_m, half_angles_deg=(10.0, 7.0), elevation_deg: float = 5.0,
                 spacing_deg=None, seed: int = 0) -> tuple:
    """Boards and vehicle poses for ``ranges_m``: ``(boards tuple, T_w_b (K,4,4))``.

    Board ``k``'s face is perpendicular to ``c0``'s optical axis at depth exactly ``ranges_m[k]``
    when the vehicle is at ``T_w_b[k]``; it is centred on the axis horizontally and at
    ``elevation_deg`` above it (default 5 deg: with a 7 deg half-height the board spans -2..+12 deg,
    above the horizon up to ``h / tan(2 deg)`` = 34 m for a 1.2 m camera height, so the ground never
    clips it). Its up is the camera's -y. Every board carries the *same* texture (seed ``seed``), so
    every range shows identical image content at the same pixel scale. The layout uses only ``c0``
    (``with_baseline`` and ``cam1.*`` overrides move c1 only), so one layout serves every baseline.
    """
    ranges = np.asarray(ranges_m, float).ravel()
    if ranges.size == 0 or np.any(ranges <= 0):
        raise SceneError(f"targets.ranges: expected positive metres, got {ranges_m!r}")
    hw_deg, hh_deg = map(float, half_angles_deg)
    spacing = float(spacing_deg) if spacing_deg is not None else 360.0 / ranges.size
    if spacing < 2 * hw_deg + 17.0:
        raise SceneError(f"targets: azimuth spacing {spacing:.1f} deg < 2*half_width + 17 deg "
                         f"({2 * hw_deg + 17:.1f}); use fewer ranges or smaller boards")
    T_b_c0 = rig.cameras[0].T_b_c_array
    boards, poses = [], []
    for k, r in enumerate(ranges):
        T_w_b = yaw_T(np.radians(k * spacing))
        T_w_c0 = T_w_b @ T_b_c0
        R_w_board = np.column_stack([T_w_c0[:3, 2], -T_w_c0[:3, 0], -T_w_c0[:3, 1]])
        center = T_w_c0[:3, 3] + r * T_w_c0[:3, 2] - r * np.tan(np.radians(elevation_deg)) * T_w_c0[:3, 1]
        boards.append(Board(name=str(k), center_w=tuple(center), R_w_board=tuple(map(tuple, R_w_board)),
                            half_w=r * np.tan(np.radians(hw_deg)), half_h=r * np.tan(np.radians(hh_deg)),
                            thickness=0.02, tex_seed=int(seed)))
        poses.append(T_w_b)
    return tuple(boards), np.array(poses)
