"""Render the rig's cameras: RGB (or gray), depth along the optical axis, segmentation.

One off-screen GL context, ``MjrContext`` and ``MjvScene`` serve every camera of the rig (the
off-screen buffer is ``offwidth x offheight``, at least the largest camera; each camera renders
into a viewport of its own size), so no context is duplicated per camera or per size. No
``mj_forward``: the world
pose is set by :meth:`sim.world.World.set_vehicle_pose` (kinematics + camlight only).
Per camera and frame: one ``mjv_updateScene`` and one colour ``mjr_render``; if depth or
segmentation is requested, one more ``mjr_render`` in segmentation mode that yields both (it
draws no skybox, so sky pixels keep the far-plane depth and become ``inf``).

Depth: MuJoCo renders with reversed Z into a float depth buffer; we invert its projection
exactly (in float64) to eye-space z, which *is* the distance along the optical axis (OpenCV
camera z), not along the ray (verified in tests/test_render_depth.py). Pixels that see no
surface within ``zfar`` get ``inf``.

Supersampling (``supersample`` = odd s > 1, scenario override ``render.supersample=s``): each camera is
rendered at s x its resolution (same frustum: MuJoCo's intrinsics are in sensor units) and each
output pixel is the mean of its s x s sub-pixels. Without it the GPU's texture filtering (mipmaps,
chosen per pixel footprint) makes ground texture seen at grazing angles move against the geometry by
~0.03 px per frame under forward motion (docs/consistency.md); at s = 3 that drops to ~0.005 px.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Optional

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from rigs.model import Rig  # noqa: E402
from sim.generate_config import check_supersample  # noqa: E402
from sim.errors import SimError  # noqa: E402
from sim.stage_timer import NO_TIMER  # noqa: E402
from sim.world import World  # noqa: E402
from rigs.image import to_gray  # noqa: E402
from sim.vehicles import VEHICLE_GROUP  # noqa: E402


@dataclass
class RenderedFrame:
    """Images of all rig cameras for one pose, in rig camera order.

    ``images``: (H,W,3) uint8 RGB or (H,W) uint8 gray; ``depth``: (H,W) float32 metres along the
    optical axis (inf = nothing within zfar) or None; ``seg``: (H,W,2) int32 ``(geom id or -1,
    dynamic flag)`` with flag 1 for geoms named ``dyn/...``, or None.
    """

    images: list
    depth: Optional[list] = None
    seg: Optional[list] = None


def _depth_coefficients(model) -> tuple:
    """(c, d, zfar) with eye depth = d / (buffer + c) for MuJoCo's reversed-Z projection.

    Mirrors ``mujoco.Renderer``: the float32 near/far that ``glFrustum`` saw, then
    ``c = n / (f - n)``, ``d = f n / (f - n)`` in float64.
    """
    ext = model.stat.extent
    n = np.float64(np.float32(model.vis.map.znear * ext))
    f = np.float64(np.float32(model.vis.map.zfar * ext))
    return n / (f - n), f * n / (f - n), f


def _downsample(rgb, depth, seg, ss: int) -> tuple:
    """``ss`` x ``ss`` supersampled canvas -> output resolution: colour is the mean over each pixel's
    ``ss x ss`` sub-pixels (a box filter over the pixel's area, as a sensor integrates light);
    depth and segmentation are the centre sub-pixel's (the exact ray through the pixel centre:
    OpenCV pixel (u, v) is sub-pixel (ss u + (ss-1)/2, ss v + (ss-1)/2))."""
    if ss == 1:
        return rgb, depth, seg
    H, W = rgb.shape[0] // ss, rgb.shape[1] // ss
    mean = rgb.reshape(H, ss, W, ss, -1).astype(np.float32).mean(axis=(1, 3))
    rgb = np.clip(np.rint(mean), 0, 255).astype(np.uint8)
    c = (ss - 1) // 2
    depth = None if depth is None else np.ascontiguousarray(depth[c::ss, c::ss])
    seg = None if seg is None else np.ascontiguousarray(seg[c::ss, c::ss])
    return rgb, depth, seg


class StereoRenderer:
    """Render all cameras of ``world``'s rig. Use as a context manager (or call ``close()``)."""

    def __init__(self, world: World, rig: Optional[Rig] = None, depth: bool = False,
                 segmentation: bool = False, gray: bool = False, show_vehicle: bool = True,
                 max_geom: int = 20000, supersample: int = 1, timer=NO_TIMER):
        self.world, self.rig = world, rig or world.rig
        self.timer = timer          # sim.stage_timer.StageTimer: stage "read-back" (mjr_readPixels, flips)
        if self.rig != world.rig:
            raise SimError(f"StereoRenderer: rig {self.rig.name!r} is not the rig the world was built "
                           f"with ({world.rig.name!r}); build the world with this rig")
        self.supersample = check_supersample(supersample)
        self.depth, self.segmentation, self.gray = depth, segmentation, gray
        m = world.model
        g = m.vis.global_
        g.offwidth = max(int(g.offwidth), self.supersample * max(c.width for c in world.render_rig.cameras))
        g.offheight = max(int(g.offheight), self.supersample * max(c.height for c in world.render_rig.cameras))
        self._gl = None
        self._ctx = None
        from mujoco.gl_context import GLContext
        self._gl = GLContext(m.vis.global_.offwidth, m.vis.global_.offheight)
        self._gl.make_current()
        self._ctx = mujoco.MjrContext(m, mujoco.mjtFontScale.mjFONTSCALE_100.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._ctx)
        self._ctx.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self.gl_renderer = _gl_renderer()   # e.g. "llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H100 .../PCIe"
        self._scn = mujoco.MjvScene(m, maxgeom=max_geom)
        self._scn.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self._opt = self._make_option(show_vehicle)
        self._cams = [self._make_camera(i) for i in world.camera_ids]
        self._dyn = np.array([(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "").startswith("dyn/")
                              for g in range(m.ngeom)], dtype=np.int32)
        self._depth_coef = _depth_coefficients(m)

    @staticmethod
    def _make_option(show_vehicle: bool):
        opt = mujoco.MjvOption()
        opt.geomgroup[:] = 1
        opt.geomgroup[VEHICLE_GROUP] = 1 if show_vehicle else 0
        opt.sitegroup[:] = 0
        return opt

    @staticmethod
    def _make_camera(cam_id: int):
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        cam.fixedcamid = cam_id
        return cam

    # -- public -------------------------------------------------------------------------------
    def render(self, T_w_b: np.ndarray, dynamic_state: Optional[dict] = None) -> RenderedFrame:
        """Pose the vehicle at (4,4) ``T_w_b`` (and mocap bodies ``{name: T_w_x}``), render all cameras.

        Cameras with lens distortion are rendered on their pinhole canvas and warped with the
        world's :class:`sim.distortion.DistortionMap` (bilinear for images, nearest for depth/seg).
        """
        if self._ctx is None:
            raise SimError("StereoRenderer.render: called after close()")
        self.world.set_vehicle_pose(T_w_b, dynamic_state)
        self._gl.make_current()
        images, depths, segs = [], [], []
        for cam, cam_obj, dmap in zip(self.world.render_rig.cameras, self._cams, self.world.distortion_maps):
            ss = self.supersample
            rgb, dep, seg = _downsample(*self._render_camera(cam.width * ss, cam.height * ss, cam_obj), ss)
            if dmap is not None:
                rgb = dmap.apply(rgb)
                dep = dmap.apply_depth(dep) if dep is not None else None
                seg = dmap.apply_seg(seg) if seg is not None else None
            images.append(to_gray(rgb) if self.gray else rgb)
            depths.append(dep)
            segs.append(seg)
        return RenderedFrame(images, depths if self.depth else None, segs if self.segmentation else None)

    def close(self) -> None:
        if self._ctx is not None and self._gl is not None:
            with self._gl.as_current():
                self._ctx.free()
        self._ctx = None
        if self._gl is not None:
            self._gl.free()
        self._gl = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    # -- internals ------------------------------------------------------------------------------
    def _render_camera(self, W: int, H: int, cam_obj) -> tuple:
        m, d, scn = self.world.model, self.world.data, self._scn
        rect = mujoco.MjrRect(0, 0, W, H)
        mujoco.mjv_updateScene(m, d, self._opt, None, cam_obj, mujoco.mjtCatBit.mjCAT_ALL.value, scn)
        rgb = np.empty((H, W, 3), np.uint8)
        mujoco.mjr_render(rect, scn, self._ctx)
        with self.timer.stage("read-back"):
            mujoco.mjr_readPixels(rgb, None, rect, self._ctx)
            rgb = np.ascontiguousarray(rgb[::-1])
        depth = seg = None
        if self.depth or self.segmentation:
            ids, zbuf = self._id_pass(rect, W, H)
            depth = self._to_metres(zbuf[::-1]) if self.depth else None
            seg = self._decode_ids(ids[::-1]) if self.segmentation else None
        return rgb, depth, seg

    def _id_pass(self, rect, W: int, H: int) -> tuple:
        """Second pass in segmentation mode: id colours and depth, no skybox (whose far-away
        sphere would otherwise write a finite depth, ~140 m, into sky pixels)."""
        scn = self._scn
        flags = scn.flags.copy()
        scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
        scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            ids = np.empty((H, W, 3), np.uint8)
            zbuf = np.empty((H, W), np.float32) if self.depth else None
            mujoco.mjr_render(rect, scn, self._ctx)
            with self.timer.stage("read-back"):
                mujoco.mjr_readPixels(ids, zbuf, rect, self._ctx)
        finally:
            np.copyto(scn.flags, flags)
        return ids, zbuf

    def _to_metres(self, zbuf: np.ndarray) -> np.ndarray:
        """(H,W) reversed-Z buffer -> (H,W) float32 eye depth (m); inf where nothing was drawn."""
        c, dcoef, zfar = self._depth_coef
        z = dcoef / (zbuf.astype(np.float64) + c)
        z[(zbuf <= 0) | (z >= zfar * (1 - 1e-6))] = np.inf
        return z.astype(np.float32)

    def _decode_ids(self, ids: np.ndarray) -> np.ndarray:
        """(H,W,3) uint8 id colours -> (H,W,2) int32 (geom id | -1, dynamic flag)."""
        scn = self._scn
        segid = (ids.astype(np.int64) * np.array([1, 256, 65536])).sum(axis=2)
        lut = np.full((scn.ngeom + 1, 2), -1, np.int32)
        lut[:, 1] = 0
        for g in scn.geoms[:scn.ngeom]:
            if g.segid >= 0 and g.objtype == mujoco.mjtObj.mjOBJ_GEOM:
                lut[g.segid + 1] = (g.objid, self._dyn[g.objid])
        return lut[np.clip(segid, 0, scn.ngeom)]


def warm_up_gl() -> None:
    """Initialise the GL back-end's device display ahead of the first renderer, from any thread: with
    ``MUJOCO_GL=egl`` MuJoCo opens the EGL device display once per process (its driver's start-up) when
    the first context is made; making and freeing one context here does that, so that a later
    :class:`StereoRenderer` only makes its own context. Other back-ends: nothing."""
    if os.environ.get("MUJOCO_GL", "").lower() != "egl":
        return
    from mujoco.gl_context import GLContext
    GLContext(1, 1).free()


def _gl_renderer() -> str:
    """``GL_RENDERER`` of the current context: the device that draws (PyOpenGL, which MuJoCo's EGL and
    OSMesa back-ends use themselves)."""
    from OpenGL import GL
    name = GL.glGetString(GL.GL_RENDERER)
    return name.decode(errors="replace") if name else ""
