"""Does the traffic look like traffic to a feature tracker? Shi-Tomasi corner density on the actors against the
background, and the fraction of tracked features on moving actors, from the true segmentation.

Corner density: every Shi-Tomasi corner of a left image (``goodFeaturesToTrack`` without a count limit,
quality 0.01, 5 px apart, 3 x 3 block) is counted on the region its pixel belongs to: *actors* (a segmentation
id of an actor, moving or not), *background* (every other pixel, sky included) and *static geometry* (the
background without the sky). Density = corners per 1000 pixels, summed over the sampled frames (counts over
counts, so a frame with a large actor weighs more). ``ratio`` = actors / background is the figure judged
(the sky has no corners, so it is the stricter of the two; ``ratio_static`` excludes it).

The dynamic fraction is :func:`sim.app.validation.dynamic_fraction.dynamic_fraction` (the ``vins`` estimator's
VINS-Mono front-end, on the left camera).

Frames: either a generated EuRoC folder written with ``--segmentation`` (:func:`dataset_frames`) or blocks of
consecutive frames rendered in memory from a scenario (:func:`scenario_frames`): ``n_blocks`` blocks of
``block_frames`` frames, their starts evenly spread over the route, rendered exactly as ``generate`` would
(same poses, actor states and image noise stream), so a block's figures equal those of the same frames of the
dataset. Tracking restarts at each block.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigs.rig_yaml import load_rig
from sim.app.validation.dynamic_fraction import dynamic_fraction, track_features
from sim.errors import SimError
from sim.generate import resolve
from sim.rng import indexed_stream
from sim.sensors.camera import StereoCamera, add_noise

DENSITY_RATIO_TARGET = 1.5
DYNAMIC_FRACTION_TARGET = 0.15


@dataclass(frozen=True)
class CornerConfig:
    quality: float = 0.01
    min_distance_px: int = 5
    block_px: int = 3


@dataclass(frozen=True)
class CornerDensity:
    """Corner and pixel counts per region over ``n_frames`` frames."""

    n_frames: int
    actor_corners: int
    actor_px: int
    background_corners: int
    background_px: int
    static_corners: int
    static_px: int

    @staticmethod
    def _per_k(c, px):
        return 1e3 * c / px if px else float("nan")

    @property
    def actor_density(self) -> float:
        return self._per_k(self.actor_corners, self.actor_px)

    @property
    def background_density(self) -> float:
        return self._per_k(self.background_corners, self.background_px)

    @property
    def static_density(self) -> float:
        return self._per_k(self.static_corners, self.static_px)

    @property
    def ratio(self) -> float:
        return self.actor_density / self.background_density if self.background_corners else float("nan")

    @property
    def ratio_static(self) -> float:
        return self.actor_density / self.static_density if self.static_corners else float("nan")

    def __add__(self, other: "CornerDensity") -> "CornerDensity":
        return CornerDensity(*(a + b for a, b in zip(dataclasses.astuple(self), dataclasses.astuple(other))))


def shi_tomasi(img: np.ndarray, config: CornerConfig = CornerConfig()) -> np.ndarray:
    """(N, 2) float pixel (x, y) of every Shi-Tomasi corner of grey ``img`` (H, W) uint8."""
    import cv2
    pts = cv2.goodFeaturesToTrack(img, 0, config.quality, config.min_distance_px, blockSize=config.block_px)
    return np.empty((0, 2)) if pts is None else pts.reshape(-1, 2)


def corner_density(images, seg_ids, actor_ids, config: CornerConfig = CornerConfig()) -> CornerDensity:
    """Corner counts of grey ``images`` by region of ``seg_ids[k]`` ((H, W) int maps; 0 = nothing rendered,
    the sky); ``actor_ids``: the segmentation ids of actors."""
    actors = np.array(sorted(set(int(i) for i in actor_ids)), dtype=np.int64)
    total = CornerDensity(0, 0, 0, 0, 0, 0, 0)
    for img, seg in zip(images, seg_ids):
        seg = np.asarray(seg)
        is_actor = np.isin(seg, actors)
        is_static = (seg > 0) & ~is_actor
        pts = shi_tomasi(img, config)
        u = np.clip(np.rint(pts[:, 0]).astype(int), 0, seg.shape[1] - 1)
        v = np.clip(np.rint(pts[:, 1]).astype(int), 0, seg.shape[0] - 1)
        on_actor, on_static = is_actor[v, u], is_static[v, u]
        total = total + CornerDensity(1, int(on_actor.sum()), int(is_actor.sum()), int((~on_actor).sum()),
                                      int((~is_actor).sum()), int(on_static.sum()), int(is_static.sum()))
    return total


@dataclass(frozen=True)
class TrafficCheck:
    """Corner density and dynamic fraction of one scenario (or dataset) sample."""

    source: str
    density: CornerDensity
    n_features: int
    n_dynamic: int
    blocks: tuple                 # (first frame, n frames) per block

    @property
    def dynamic_fraction(self) -> float:
        return self.n_dynamic / self.n_features if self.n_features else 0.0

    @property
    def passed(self) -> bool:
        return bool(self.density.ratio <= DENSITY_RATIO_TARGET
                    and self.dynamic_fraction >= DYNAMIC_FRACTION_TARGET)

    def to_dict(self) -> dict:
        d = self.density
        return {"source": self.source, "frames": d.n_frames, "blocks": [list(b) for b in self.blocks],
                "actor_corners_per_kpx": d.actor_density, "background_corners_per_kpx": d.background_density,
                "static_corners_per_kpx": d.static_density, "ratio": d.ratio, "ratio_static": d.ratio_static,
                "actor_area_fraction": d.actor_px / max(1, d.actor_px + d.background_px),
                "actor_corner_fraction": d.actor_corners / max(1, d.actor_corners + d.background_corners),
                "tracked_features": self.n_features, "dynamic_features": self.n_dynamic,
                "dynamic_fraction": self.dynamic_fraction, "ratio_target": DENSITY_RATIO_TARGET,
                "dynamic_fraction_target": DYNAMIC_FRACTION_TARGET, "passed": self.passed}

    def table(self) -> str:
        d, r = self.density, self.to_dict()
        return "\n".join([
            f"traffic texture: {self.source}, {d.n_frames} frames in {len(self.blocks)} block(s)",
            f"  Shi-Tomasi corners per 1000 px: actors {d.actor_density:.2f}, background {d.background_density:.2f} "
            f"(static geometry without sky {d.static_density:.2f})",
            f"  actors / background = {d.ratio:.2f} (target <= {DENSITY_RATIO_TARGET}), "
            f"actors / static geometry = {d.ratio_static:.2f}",
            f"  actors cover {100 * r['actor_area_fraction']:.1f} % of the pixels and hold "
            f"{100 * r['actor_corner_fraction']:.1f} % of the corners",
            f"  tracked features on moving actors: {self.n_dynamic} / {self.n_features} = "
            f"{100 * self.dynamic_fraction:.1f} % (target >= {100 * DYNAMIC_FRACTION_TARGET:.0f} %)",
            f"  {'PASS' if self.passed else 'FAIL'}"])


# ---------------------------------------------------------------------------- frames
@dataclass(frozen=True)
class Block:
    """Consecutive frames: grey left images, segmentation id maps (seg id = geom + 1, 0 = sky), and the left
    ``camera`` (:class:`rigs.model.Camera`) that took them."""

    first: int
    images: list
    segs: list
    camera: object
    camera: object


def scenario_frames(config, n_blocks: int = 8, block_frames: int = 12, progress: bool = True):
    """``(blocks, actor_ids, moving_ids)``: :class:`Block` list rendered from ``config`` (a
    :class:`sim.generate_config.GenerateConfig`) and the segmentation ids of all / moving actors."""
    from tqdm import tqdm

    if n_blocks < 1 or block_frames < 2:
        raise SimError(f"traffic check: need at least 1 block of 2 frames, got {n_blocks} x {block_frames}")
    setup = resolve(config)
    n = len(setup.frame_t_ns)
    if n < block_frames:
        raise SimError(f"traffic check: the route has {n} frames, fewer than one block of {block_frames}")
    starts = np.unique(np.linspace(0, n - block_frames, n_blocks).round().astype(int))
    T_w_b = setup.trajectory.states(setup.frame_t_ns).T_w_b
    blocks = []
    with StereoCamera(setup.scene, setup.rig, vehicle=config.vehicle, segmentation=True,
                      supersample=setup.supersample) as camera:
        rows = setup.scene.segmentation_rows(camera.geom_names())
        bar = tqdm(total=len(starts) * block_frames, desc="render", unit="pair", disable=not progress)
        for s in starts:
            images, segs = [], []
            for k in range(s, s + block_frames):
                imgs, _, seg = camera.measure(T_w_b[k], setup.scene.actor_states(int(setup.frame_t_ns[k])))
                imgs = add_noise(imgs, setup.image_noise, indexed_stream(config.seed, "image_noise", k))
                images.append(imgs[0])
                segs.append(seg[0][..., 0].astype(np.int32) + 1)
                bar.update(1)
            blocks.append(Block(int(s), images, segs, setup.rig.cameras[0]))
        bar.close()
    return blocks, _actor_ids(rows), {r[0] for r in rows if r[2] > 0 and r[4]}


def _actor_ids(rows) -> set:
    return {int(r[0]) for r in rows if int(r[2]) > 0}


def dataset_frames(folder, max_frames: int | None = None):
    """``(blocks, actor_ids, moving_ids)`` of a generated EuRoC folder written with ``--segmentation``: one
    block of its first ``max_frames`` frames (all by default)."""
    import csv
    import cv2
    folder = Path(folder)
    cam = folder / "mav0" / "cam0"
    seg_dir = cam / "segmentation"
    ids = folder / "segmentation_ids.csv"
    if not seg_dir.is_dir() or not ids.is_file():
        raise SimError(f"{folder}: no mav0/cam0/segmentation or segmentation_ids.csv (generate with --segmentation)")
    with ids.open() as f:
        rows = list(csv.DictReader(f))
    if rows and not {"seg_id", "actor_id", "moving"} <= set(rows[0]):
        raise SimError(f"{ids}: expected columns seg_id, actor_id and moving, got {sorted(rows[0])}")
    actor_ids = {int(r["seg_id"]) for r in rows if int(r["actor_id"]) > 0}
    moving = {int(r["seg_id"]) for r in rows if int(r["moving"]) == 1}
    names = sorted(p.name for p in (cam / "data").glob("*.png"))[:max_frames]
    images = [cv2.imread(str(cam / "data" / n), cv2.IMREAD_GRAYSCALE) for n in names]
    camera = load_rig(folder / "rig.yaml").cameras[0]
    return [Block(0, images, [read_seg(seg_dir / n) for n in names], camera)], actor_ids, moving


def read_seg(path: Path) -> np.ndarray:
    """A segmentation PNG as an (H, W) int64 id map."""
    import cv2
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise SimError(f"{path}: missing or unreadable segmentation image")
    return img.astype(np.int64)


def check_traffic(blocks, actor_ids, moving_ids, source: str,
                  corners: CornerConfig = CornerConfig()) -> TrafficCheck:
    """Corner density over every frame of ``blocks`` and the dynamic fraction, tracking within each block."""
    dens = CornerDensity(0, 0, 0, 0, 0, 0, 0)
    n_feat = n_dyn = 0
    for b in blocks:
        dens = dens + corner_density(b.images, b.segs, actor_ids, corners)
        res = dynamic_fraction(b.images, b.segs, moving_ids, b.camera)
        n_feat, n_dyn = n_feat + res.n_features, n_dyn + res.n_dynamic
    return TrafficCheck(source, dens, n_feat, n_dyn, tuple((b.first, len(b.images)) for b in blocks))


def plot_features(blocks, moving_ids, path, title: str = ""):
    """Figure of one frame with its tracked features coloured static (green) / dynamic (red): the last frame of
    the block with the most dynamic features. Returns ``(block first frame + index, n static, n dynamic)``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    moving = np.array(sorted(moving_ids), dtype=np.int64)
    best = None
    for b in blocks:
        for k, pts in track_features(b.images, b.camera):
            if k != len(b.images) - 1:
                continue
            seg = b.segs[k]
            u = np.clip(np.rint(pts[:, 0]).astype(int), 0, seg.shape[1] - 1)
            v = np.clip(np.rint(pts[:, 1]).astype(int), 0, seg.shape[0] - 1)
            dyn = np.isin(seg[v, u], moving)
            if best is None or dyn.sum() > best[3].sum():
                best = (b, k, pts, dyn)
    b, k, pts, dyn = best
    fig, ax = plt.subplots(figsize=(8, 8 * b.images[k].shape[0] / b.images[k].shape[1] + 0.6))
    ax.imshow(b.images[k], cmap="gray", vmin=0, vmax=255)
    ax.contour(np.isin(b.segs[k], moving), levels=[0.5], colors="orange", linewidths=0.6)
    ax.scatter(pts[~dyn, 0], pts[~dyn, 1], s=22, facecolors="none", edgecolors="lime", label=f"static ({(~dyn).sum()})")
    ax.scatter(pts[dyn, 0], pts[dyn, 1], s=22, facecolors="none", edgecolors="red", label=f"dynamic ({dyn.sum()})")
    ax.set_axis_off()
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(f"{title}frame {b.first + k}: tracked features (orange outline: moving actors)", fontsize=9)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return b.first + k, int((~dyn).sum()), int(dyn.sum())
