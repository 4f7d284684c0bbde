"""Generation configuration: frozen, typed dataclasses whose YAML keys and ``--set`` keys are the field names.

:class:`GenerateConfig` holds the rig (a :class:`rigs.model.Rig`), the scene
(:class:`scenes.base.SceneConfig`), the vehicle motion (:class:`sim.motion.MotionConfig`), the
rendering (:class:`RenderConfig`) and the image noise (:class:`NoiseConfig`), plus the output
switches. Every value is type- and range-checked on construction (:mod:`rigs.typed_config`), so a
YAML file (:func:`load_generate_config`) and ``--set a.b=v`` (:meth:`GenerateConfig.with_overrides`)
get the same checks, and :meth:`GenerateConfig.to_dict` is the resolved whole that ``metadata.yaml``
records and :meth:`GenerateConfig.config_hash` is computed from.

``--set`` keys: a field path (``seed=3``, ``scene.texture_richness=0.3``, ``motion.vibration_pitch_deg=0.5``,
``render.supersample=3``, ``noise.image_sigma=2``, the sensor effects ``camera.exposure_ms=4``,
``calib_error.focal_ppm=500``, ``imu.time_offset_ms=5`` (short for ``imu_clock.time_offset_ms``)), ``image_noise=2`` (short for ``noise.image_sigma``),
``rig=NAME`` (a preset), or a rig override key of :mod:`rigs.overrides` with or without ``rig.``
(``baseline=0.063``, ``imu=paper002``, ``imu.rate_hz=400``, ``cam0.fx=500``, ``wheels=none``).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Optional, get_args

from rigs.kalibr_io import read_kalibr
from rigs.model import Rig
from rigs.overrides import RIG_KEYS
from rigs.presets import get_rig
from rigs.rig_yaml import rig_from_dict
from rigs.typed_config import (apply_items, check_fields, from_mapping, knob, load_dataclass, replace_path,
                               settable_keys, to_mapping)
from scenes.base import SceneConfig
from scenes.errors import SceneError
from scenes.registry import scene_class
from sim.distortion import fisheye_needed_theta
from sim.errors import SimError
from sim.motion import MotionConfig
from sim.replay import ReplayConfig
from sim.vehicles import vehicle_class
from sim.version import __version__

MAX_SUPERSAMPLE = 7
PNG_COMPRESSION = 1        # zlib level of the written PNGs, chosen by measurement (docs/simulator.md)
PngStrategy = Literal["default", "filtered", "huffman", "rle", "fixed"]
PNG_STRATEGIES = get_args(PngStrategy)
PNG_STRATEGY = "rle"       # zlib strategy of the written PNGs, chosen by measurement (docs/simulator.md)
PngFilter = Literal["all", "fast", "paeth", "avg", "up", "sub", "none"]
PNG_FILTERS = get_args(PngFilter)
PNG_FILTER = "sub"         # PNG row filter(s) tried, chosen by measurement (docs/simulator.md)
Format = Literal["euroc", "kitti", "both", "rosbag1", "rosbag2"]
DepthFormat = Literal["npy", "png16-mm", "tum", "png16"]   # png16: alias of png16-mm
FORMATS = get_args(Format)
DEPTH_FORMATS = get_args(DepthFormat)
ALIASES = {"image_noise": "noise.image_sigma", "imu.time_offset_ms": "imu_clock.time_offset_ms"}
EFFECT_PIECES = ("camera", "imu_clock", "calib_error", "replay")   # left out of to_dict() (and the hash) while all off


@dataclass(frozen=True)
class RenderConfig:
    """Rendering knobs (``render.<field>``). ``supersample``: odd, so every output pixel centre is the
    centre of one rendered sub-pixel and depth and segmentation stay exact (:mod:`sim.render`).
    ``png_compression``: zlib level of every PNG written (0 none, 9 smallest; the pixels are the same);
    ``png_strategy``: zlib's strategy (``huffman``: no string matching, ``rle``: runs only; ``default``);
    ``png_filter``: the PNG row filter(s) libpng chooses from (``all`` five per row, ``fast``, or one)."""

    supersample: int = knob(1, ge=1, le=MAX_SUPERSAMPLE, odd=True)
    png_compression: int = knob(PNG_COMPRESSION, ge=0, le=9, doc="zlib level of the written PNGs")
    png_strategy: PngStrategy = knob(PNG_STRATEGY, doc="zlib strategy of the written PNGs")
    png_filter: PngFilter = knob(PNG_FILTER, doc="PNG row filter(s) of the written PNGs")

    def __post_init__(self):
        check_fields(self, SimError, "render.")


@dataclass(frozen=True)
class NoiseConfig:
    """Image noise (``noise.<field>``): iid Gaussian per pixel, sigma in grey levels (0 = none)."""

    image_sigma: float = knob(1.0, ge=0.0)

    def __post_init__(self):
        check_fields(self, SimError, "noise.")


@dataclass(frozen=True)
class CameraEffects:
    """Sensor effects of the cameras (``camera.<field>``), all off by default (:mod:`sim.sensors.effects_timing`,
    :mod:`sim.sensors.photometric`, docs/sensor_effects.md). A frame's timestamp is the mid-exposure time of
    its centre row; ``read_noise_dn`` / ``shot_noise_gain`` > 0 replace ``noise.image_sigma``."""

    exposure_ms: float = knob(0.0, ge=0.0, le=100.0, doc="exposure time (motion blur); 0: instantaneous")
    blur_subframes: int = knob(5, ge=2, le=33, doc="renders integrated over the exposure")
    line_delay_us: float = knob(0.0, ge=0.0, le=200.0, doc="rolling shutter: row r starts (r-(h-1)/2)*delay later")
    rs_poses: int = knob(5, ge=2, le=33, doc="renders across the rolling-shutter readout")
    timestamp_jitter_us: float = knob(0.0, ge=0.0, le=10000.0, doc="std of the stamp error (seeded stream)")
    vignetting: float = knob(0.0, ge=0.0, le=1.0, doc="strength of the cos^4 fall-off (1 = full cos^4)")
    auto_exposure: bool = False
    ae_target: float = knob(0.45, gt=0.0, lt=1.0, doc="auto exposure: mean brightness aimed at (fraction of 255)")
    ae_time_constant_s: float = knob(0.3, gt=0.0, le=10.0, doc="auto exposure: gain time constant")
    read_noise_dn: float = knob(0.0, ge=0.0, le=50.0, doc="read noise std (grey levels)")
    shot_noise_gain: float = knob(0.0, ge=0.0, le=10.0, doc="grey levels per electron (shot noise)")

    def __post_init__(self):
        check_fields(self, SimError, "camera.")

    @property
    def sensor_noise(self) -> bool:
        """True when the shot + read noise model replaces the Gaussian ``noise.image_sigma``."""
        return self.read_noise_dn > 0 or self.shot_noise_gain > 0

    @property
    def multi_render(self) -> bool:
        """True when a frame is assembled from several renders (blur and/or rolling shutter)."""
        return self.exposure_ms > 0 or self.line_delay_us > 0

    @property
    def image_effects(self) -> bool:
        """True when any effect changes the images (frames then go through :class:`sim.sensors.camera.FrameExposer`)."""
        return self.multi_render or self.vignetting > 0 or self.auto_exposure or self.sensor_noise


@dataclass(frozen=True)
class ImuClock:
    """IMU clock (``imu_clock.<field>``; ``--set imu.time_offset_ms=V`` is short for it): Kalibr's / VINS-Mono's
    ``td``, ``t_imu = t_cam + td``: every IMU stamp is the true (camera-clock) time plus the offset."""

    time_offset_ms: float = knob(0.0, ge=-1000.0, le=1000.0)

    def __post_init__(self):
        check_fields(self, SimError, "imu_clock.")


@dataclass(frozen=True)
class CalibError:
    """Calibration error (``calib_error.<field>``, std of each drawn perturbation, stream ``calib_error``):
    images are rendered with the true rig, the calibration written for estimators is perturbed
    (:mod:`sim.sensors.calib_error`)."""

    focal_ppm: float = knob(0.0, ge=0.0, le=1e5, doc="fx, fy relative error (parts per million)")
    principal_px: float = knob(0.0, ge=0.0, le=50.0, doc="cx, cy error (pixels)")
    dist_rel: float = knob(0.0, ge=0.0, le=1.0, doc="relative error of each distortion coefficient")
    extrinsic_rot_deg: float = knob(0.0, ge=0.0, le=10.0, doc="per-axis rotation error of each T_b_c")
    extrinsic_trans_mm: float = knob(0.0, ge=0.0, le=100.0, doc="per-axis translation error of each T_b_c")
    stereo_disparity_px: float = knob(0.0, ge=-20.0, le=20.0,
                                      doc="disparity offset of the written stereo calibration (px, not drawn): "
                                          "the last camera's cx written this much lower, so a positive offset "
                                          "makes every stereo depth too long (fb / (d - offset))")

    def __post_init__(self):
        check_fields(self, SimError, "calib_error.")

    @property
    def active(self) -> bool:
        return any(getattr(self, f.name) != 0 for f in dataclasses.fields(self))


def check_supersample(value) -> int:
    """Validated supersampling factor (``render.supersample``): an odd integer 1..MAX_SUPERSAMPLE."""
    return RenderConfig(supersample=value).supersample


def rig_of(value) -> Rig:
    """The ``rig`` field from a preset name or ``.yaml`` path, a mapping of Rig field names (as
    ``metadata.yaml`` records it), ``{preset: NAME, set: [key=value, ...]}`` or Kalibr files
    ``{kalibr: camchain-imucam.yaml, imu: imu.yaml}`` (``imu`` optional)."""
    if isinstance(value, str):
        return get_rig(value)
    if isinstance(value, Mapping) and "preset" in value and set(value) <= {"preset", "set"}:
        return get_rig(value["preset"], value.get("set") or ())
    if isinstance(value, Mapping) and "kalibr" in value and set(value) <= {"kalibr", "imu"}:
        return read_kalibr(value["kalibr"], value.get("imu"), name=Path(str(value["kalibr"])).stem)
    if isinstance(value, Mapping):
        return rig_from_dict(dict(value), source="rig")
    raise SimError(f"rig: expected a preset name, a rig mapping, {{preset, set}} or {{kalibr, imu}}, got {value!r}")


def scene_of(value) -> SceneConfig:
    """The ``scene`` field from a scene name or a mapping of SceneConfig field names; its ``seed``
    defaults to None (= the config's ``seed``)."""
    if isinstance(value, str):
        return SceneConfig(name=value, seed=None)
    if isinstance(value, Mapping):
        return from_mapping(SceneConfig, {"seed": None, **value}, SceneError, "scene")
    raise SceneError(f"scene: expected a scene name or a mapping of scene fields, got {value!r}")


@dataclass(frozen=True)
class GenerateConfig:
    """Everything that determines a generated dataset (together with the package version)."""

    KEY_ALIASES = ALIASES                   # short --set keys (rigs.typed_config.resolve_key); not a field

    scene: SceneConfig = knob(default_factory=lambda: SceneConfig(seed=None), parse=scene_of)
    rig: Rig = knob(default_factory=lambda: rig_of("cart27"), parse=rig_of, keys=RIG_KEYS, bare=True)
    duration_s: Optional[float] = knob(None, gt=0.0, doc="seconds to simulate; None: the whole route")
    seed: int = knob(0, ge=0)
    format: Format = "euroc"
    depth: bool = False
    depth_format: DepthFormat = "npy"
    segmentation: bool = False
    ideal: bool = False
    images: bool = True
    vehicle: str = "cart"
    rgb: bool = False
    motion: MotionConfig = knob(default_factory=MotionConfig)
    render: RenderConfig = knob(default_factory=RenderConfig)
    noise: NoiseConfig = knob(default_factory=NoiseConfig)
    camera: CameraEffects = knob(default_factory=CameraEffects)
    imu_clock: ImuClock = knob(default_factory=ImuClock)
    calib_error: CalibError = knob(default_factory=CalibError)
    replay: ReplayConfig = knob(default_factory=ReplayConfig)   # --motion FILE (sim.replay); off: file None

    def __post_init__(self):
        check_fields(self, SimError)
        try:
            scene_class(self.scene.name)          # a registered name or a plug-in "package.module:SceneClass"
        except SceneError as e:
            raise SceneError(f"scene.name: {e}") from None
        if vehicle_class(self.vehicle).dims is None and self.rig.wheels is not None:
            raise SimError(f"vehicle: {self.vehicle!r} has no wheels, but rig {self.rig.name!r} has wheel encoders")
        self.rig.check_stereo()                   # two cameras at one position: no stereo geometry
        if self.images:                           # a fisheye wider than a pinhole canvas holds: refused up front
            for cam in self.rig.cameras:
                if cam.is_fisheye:
                    fisheye_needed_theta(cam)
        if not self.images and self.format in ("kitti", "both"):
            raise SimError(f"images: false (--no-images) with format {self.format!r}: KITTI odometry holds "
                           f"images only, nothing written; use format euroc for IMU and ground truth alone")

    @property
    def scene_config(self) -> SceneConfig:
        """The scene configuration with its seed resolved (None -> ``seed``)."""
        return self.scene if self.scene.seed is not None else dataclasses.replace(self.scene, seed=self.seed)

    def with_value(self, key: str, value) -> "GenerateConfig":
        """A copy with dotted ``key`` set to the parsed ``value`` (see the module docstring)."""
        return replace_path(self, key, value, SimError)

    def with_overrides(self, items, source: str = "override") -> "GenerateConfig":
        """Apply ``key=value`` strings in order (values parsed as YAML); errors are one line
        ``<source> '<item>': <field>: <problem>``."""
        return apply_items(self, items, SimError, source)

    def valid_keys(self) -> list:
        """Every ``--set`` key, the rig's override keys included."""
        return settable_keys(self)

    def to_dict(self) -> dict:
        """The resolved whole as plain builtins (the rig in full); :func:`load_generate_config` reads it back.
        A sensor-effect piece (``camera``, ``imu_clock``, ``calib_error``) left at its default (all off) is
        omitted, so a configuration without effects keeps its dict, hash and dataset bytes."""
        out = to_mapping(self)
        for name in EFFECT_PIECES:
            if getattr(self, name) == type(getattr(self, name))():
                out.pop(name)
        return out

    def config_hash(self) -> str:
        """Stable hash of the configuration (for caching generated scenarios)."""
        blob = json.dumps({"config": self.to_dict(), "version": __version__}, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


def load_generate_config(path) -> GenerateConfig:
    """Load a :class:`GenerateConfig` from YAML whose keys are the field names (nested mappings for
    ``scene``, ``motion``, ``render``, ``noise``; ``rig`` as :func:`rig_of` accepts). The ``config``
    block of a dataset's ``metadata.yaml`` is such a file's content."""
    return load_dataclass(GenerateConfig, path, SimError)
