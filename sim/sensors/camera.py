"""The stereo camera as a sensor: :meth:`StereoCamera.measure` renders the clean images for a vehicle
pose (the world, the renderer and the exact lens distortion are :mod:`sim.world`, :mod:`sim.render`,
:mod:`sim.distortion`); :func:`add_noise` is the separate noise step, drawing from the generator it is
given (the simulator passes frame ``k``'s ``image_noise`` stream, ``sim.rng.indexed_stream``).
:class:`FrameExposer` adds the sensor effects of :class:`sim.generate_config.CameraEffects` (motion blur, rolling
shutter, vignetting, auto exposure, shot + read noise; docs/sensor_effects.md).
"""
from __future__ import annotations

import numpy as np

from rigs.image import to_gray
from rigs.image_noise import add_quantized_noise
from sim.errors import SimError
from sim.rng import indexed_stream
from sim.sensors.effects_timing import assemble, exposure_plan
from sim.sensors.photometric import AutoExposure, quantize, sensor_noise, vignetting_map
from sim.stage_timer import NO_TIMER


class StereoCamera:
    """The rig's first two cameras on ``vehicle`` in ``scene``. Images are 8-bit grey
    (:func:`rigs.image.to_gray`) unless ``rgb``; ``depth`` / ``segmentation`` as :class:`sim.render.StereoRenderer`.
    Use as a context manager (it owns an off-screen GL context). ``timer``: a
    :class:`sim.stage_timer.StageTimer` for the renderer's read-back (None: not timed). ``world``: the
    compiled world of ``scene``, ``rig`` and ``vehicle`` when built already (:mod:`sim.world_handoff`);
    None: built here."""

    def __init__(self, scene, rig, vehicle: str = "cart", depth: bool = False, segmentation: bool = False,
                 supersample: int = 1, rgb: bool = False, timer=None, world=None):
        from sim.render import StereoRenderer
        from sim.world import build_world
        self.world = world if world is not None else build_world(scene, rig, vehicle=vehicle)
        self.rgb = bool(rgb)
        self._renderer = StereoRenderer(self.world, rig, depth=depth, segmentation=segmentation,
                                        supersample=supersample, timer=timer or NO_TIMER)

    def measure(self, T_w_b: np.ndarray, dynamic_state: dict | None = None):
        """Clean stereo measurement at body pose ``T_w_b`` (4,4), the scene's actors at ``dynamic_state``
        (``{mocap body: T_w_x}``, :meth:`scenes.base.Scene.actor_states`): ``(images [left, right], depth,
        seg)``, lens distortion applied by the renderer (exact inverse map)."""
        fr = self._renderer.render(T_w_b, dynamic_state)
        images = [img if img.ndim == 2 or self.rgb else to_gray(img) for img in fr.images[:2]]
        return images, fr.depth, fr.seg

    @property
    def gl_renderer(self) -> str:
        """The GL renderer that draws (``GL_RENDERER``), e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``."""
        return self._renderer.gl_renderer

    def geom_names(self) -> list:
        """Name of every geom of the compiled world, by geom id ("" if unnamed)."""
        import mujoco
        m = self.world.model
        return [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(m.ngeom)]

    def close(self) -> None:
        self._renderer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def add_noise(images, sigma: float, rng: np.random.Generator) -> list:
    """The camera's noise step: :func:`rigs.image_noise.add_quantized_noise` (the rounded Gaussian
    offsets drawn directly) on each image in order, all from ``rng``; ``sigma = 0`` returns the images
    unchanged and draws nothing."""
    return [add_quantized_noise(img, sigma, rng) for img in images]


class FrameExposer:
    """Frame ``k`` of ``camera`` (a :class:`StereoCamera`) with the sensor effects of ``effects``
    (:class:`sim.generate_config.CameraEffects`): the renders of the exposure plan
    (:mod:`sim.sensors.effects_timing`) assembled row by row, then vignetting and the auto exposure gain
    (:mod:`sim.sensors.photometric`) in floating point, then the noise step: shot + read noise (stream
    ``sensor_noise``, index k) when set, else rounding and :func:`add_noise` with ``image_sigma``
    (stream ``image_noise``, index k, as without effects). ``noisy = False`` (``--ideal``) skips noise.
    Auto exposure makes frame k depend on frames < k: expose frames in order from 0."""

    def __init__(self, camera, rig, effects, period_s: float, seed: int, image_sigma: float, noisy: bool = True):
        cams = rig.cameras[:2]
        if effects.line_delay_us > 0 and len({c.height for c in cams}) > 1:
            raise SimError(f"camera.line_delay_us: rig {rig.name!r} has cameras of different heights; "
                           f"rolling shutter needs one readout for both")
        self.camera, self.effects, self.seed = camera, effects, int(seed)
        self.sigma, self.noisy = float(image_sigma), bool(noisy)
        self.plan = exposure_plan(effects.exposure_ms, effects.line_delay_us, cams[0].height,
                                  effects.blur_subframes, effects.rs_poses)
        self.vignette = [vignetting_map(c, effects.vignetting) for c in cams] if effects.vignetting > 0 else None
        self.ae = AutoExposure(effects.ae_target, effects.ae_time_constant_s, period_s) if effects.auto_exposure \
            else None

    def expose(self, k: int, t_ns: int, pose_at, actors_at) -> tuple:
        """``(images [left, right] uint8, depth, seg, gain)`` of frame ``k`` at (mid-exposure, centre-row)
        time ``t_ns``; ``pose_at(times_ns) -> (N,4,4) T_w_b``, ``actors_at(t_ns) -> dynamic state``.
        :meth:`render` then :meth:`finish`."""
        images, depth, seg, gain = self.render(k, t_ns, pose_at, actors_at)
        return self.finish(k, images, gain), depth, seg, gain

    def render(self, k: int, t_ns: int, pose_at, actors_at) -> tuple:
        """The in-order part of frame ``k`` (on the renderer's thread): ``(images [left, right] float,
        depth, seg, gain)``, the renders assembled and vignetted, the auto exposure stepped; the images
        are at unit gain."""
        plan = self.plan
        times = int(t_ns) + plan.offsets_ns
        T_w_b = pose_at(times)
        renders = [self.camera.measure(T_w_b[n], actors_at(int(times[n]))) for n in range(len(times))]
        _, depth, seg = renders[plan.centre]
        images = [assemble([r[0][i] for r in renders], plan.weights) for i in range(2)]
        if self.vignette is not None:
            images = [img * (v if img.ndim == 2 else v[..., None]) for img, v in zip(images, self.vignette)]
        gain = 1.0
        if self.ae is not None:
            gain = self.ae.gain
            self.ae.update(float(images[0].mean()))
        return images, depth, seg, gain

    def finish(self, k: int, images, gain: float) -> list:
        """The rest of frame ``k``, independent of other frames (any thread, any order): the gain, then
        the noise step; ``images`` from :meth:`render`. Returns [left, right] uint8."""
        if self.ae is not None:
            images = [img * gain for img in images]
        e = self.effects
        if self.noisy and e.sensor_noise:
            rng = indexed_stream(self.seed, "sensor_noise", k)
            return [sensor_noise(img, e.read_noise_dn, e.shot_noise_gain, rng) for img in images]
        images = [quantize(img) for img in images]
        if self.noisy:
            images = add_noise(images, self.sigma, indexed_stream(self.seed, "image_noise", k))
        return images
