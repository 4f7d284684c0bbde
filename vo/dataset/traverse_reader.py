"""Read a stop-and-go traverse dataset (docs/dataset_layout.md, "Traverse datasets") into the
cross-site localizer's records (:mod:`vo.crosssite.types`).

``read_traverse(path)`` gives a :class:`Traverse`: the :class:`~vo.crosssite.types.Site` list (each
pair's ``T_b_c0`` from the mast model and the *commanded* angles, as the rover knows them, or the
true ones with ``angles="true"``; the prior is the written dead-reckoning pose and covariance), the
true site poses, and the drive streams on request. Every problem raises a one-line ``DatasetError``
naming the file.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from vo.dataset.csvio import read_numeric_csv
from vo.errors import DatasetError


@dataclass(frozen=True)
class Traverse:
    """``sites`` (tuple of Site), ``T_w_b_true`` (S,4,4) and ``site_t_ns`` (S,), the ``metadata`` dict,
    ``arc_length_m`` (S,) distance driven to each site, and the dataset ``root``."""

    sites: tuple
    T_w_b_true: np.ndarray
    site_t_ns: np.ndarray
    arc_length_m: np.ndarray
    metadata: dict
    root: Path


def _yaml(path: Path) -> dict:
    if not path.is_file():
        raise DatasetError(f"{path}: missing (not a traverse dataset?)")
    try:
        d = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise DatasetError(f"{path}: not valid YAML ({' '.join(str(e).split())[:120]})") from None
    if not isinstance(d, dict):
        raise DatasetError(f"{path}: expected a mapping")
    return d


def is_traverse(path) -> bool:
    """True if ``path`` holds a traverse dataset's ``metadata.yaml``."""
    p = Path(path) / "metadata.yaml"
    try:
        return p.is_file() and yaml.safe_load(p.read_text()).get("kind") == "traverse"
    except (yaml.YAMLError, AttributeError):
        return False


def mast_model(meta: dict, where: str) -> tuple:
    """(T_b_mast (4,4), T_head_c (K,4,4)) from ``metadata.yaml``'s ``mast`` block."""
    try:
        m = meta["mast"]
        T_b_mast, T_head_c = np.asarray(m["T_b_mast"], float), np.asarray(m["T_head_c"], float)
    except (KeyError, TypeError, ValueError):
        raise DatasetError(f"{where}: 'mast' must hold T_b_mast (4x4) and T_head_c (Kx4x4)") from None
    if T_b_mast.shape != (4, 4) or T_head_c.ndim != 3 or T_head_c.shape[1:] != (4, 4) or T_head_c.shape[0] < 2:
        raise DatasetError(f"{where}: mast.T_b_mast must be 4x4 and mast.T_head_c Kx4x4 with K >= 2")
    return T_b_mast, T_head_c


def stereo_cal(meta: dict, T_head_c: np.ndarray, where: str):
    """The rectified stereo calibration of cameras 0 and 1 (``rig`` block + mast model)."""
    from vo.crosssite.types import StereoCal
    try:
        c0 = meta["rig"]["cameras"][0]
        K = np.array([[c0["fx"], 0, c0["cx"]], [0, c0["fy"], c0["cy"]], [0, 0, 1.0]], float)
        W, H = int(c0["width"]), int(c0["height"])
    except (KeyError, TypeError, IndexError, ValueError):
        raise DatasetError(f"{where}: rig.cameras[0] must give fx, fy, cx, cy, width, height") from None
    T_c0_c1 = np.linalg.inv(T_head_c[0]) @ T_head_c[1]
    T_c0_c1[np.abs(T_c0_c1) < 1e-12] = 0.0
    return StereoCal(K, T_c0_c1, W, H)


def describe_non_traverse(root: Path, meta: dict) -> str:
    """What a dataset folder that is not a traverse holds, in a few words (for the error of a reader)."""
    if meta.get("kind") is not None:
        return f"a dataset of kind {meta.get('kind')!r}"
    fmt = meta.get("format") or ("euroc" if (root / "mav0").is_dir() else "kitti" if (root / "sequences").is_dir()
                                 else None)
    if fmt is None:
        return "a folder whose metadata.yaml names no dataset kind"
    scene = meta.get("scene")
    scene = scene.get("name") if isinstance(scene, dict) else scene
    n = meta.get("n_frames")
    return (f"a {fmt.upper() if fmt == 'kitti' else 'EuRoC'} stereo sequence" + (f" of {n} frames" if n else "")
            + (f" ({scene})" if scene else ""))


def read_traverse(path, angles: str = "commanded", max_sites: int = 0) -> Traverse:
    """The traverse at ``path``; ``angles`` "commanded" (default) or "true" for each pair's ``T_b_c0``."""
    import cv2
    from vo.crosssite.types import Site, StereoPair, mast_T_b_c
    root = Path(path)
    if angles not in ("commanded", "true"):
        raise DatasetError(f"traverse angles: {angles!r}; valid: commanded, true")
    meta = _yaml(root / "metadata.yaml")
    if meta.get("kind") != "traverse":
        raise DatasetError(f"{root}: {describe_non_traverse(root, meta)}, not a stop-and-go traverse; "
                           f"localize needs per-site panoramas (sites/site_NN/) made by "
                           f"`vo-testbed generate --scenario yutu-traverse --out DIR`")
    T_b_mast, T_head_c = mast_model(meta, str(root / "metadata.yaml"))
    cal = stereo_cal(meta, T_head_c, str(root / "metadata.yaml"))
    n = int(meta.get("n_sites", 0))
    n = min(n, max_sites) if max_sites else n
    sites, T_true, t_sites, arc = [], [], [], []
    key = "cmd" if angles == "commanded" else "true"
    for k in range(n):
        folder = root / "sites" / f"site_{k:02d}"
        d = _yaml(folder / "site.yaml")
        pairs = []
        for p in d.get("pairs") or []:
            imgs = []
            for side in ("left", "right"):
                f = folder / str(p[side])
                img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
                if img is None:
                    raise DatasetError(f"{f}: missing or unreadable image")
                imgs.append(img)
            pan, tilt = float(p[f"pan_{key}_rad"]), float(p[f"tilt_{key}_rad"])
            pairs.append(StereoPair(imgs[0], imgs[1], mast_T_b_c(T_b_mast, pan, tilt, T_head_c[0]), pan, tilt))
        try:
            sites.append(Site(k, int(d["t_ns"]), tuple(pairs), cal, np.asarray(d["T_w_b_dr"], float),
                              np.asarray(d["cov_dr"], float)))
            T_true.append(np.asarray(d["T_w_b_true"], float))
        except KeyError as e:
            raise DatasetError(f"{folder / 'site.yaml'}: missing key {e}") from None
        t_sites.append(int(d["t_ns"]))
        arc.append(float(d.get("arc_length_m", np.nan)))
    return Traverse(tuple(sites), np.array(T_true), np.array(t_sites, np.int64), np.array(arc), meta, root)


def read_drive(path) -> dict:
    """The drive streams: ``imu`` (t_ns, (N,6) gyro+accel), ``wheels`` (t_ns, (N,2) ticks),
    ``groundtruth`` (t_ns, (N,16) EuRoC body truth)."""
    root = Path(path) / "drive"
    return {"imu": read_numeric_csv(root / "imu0.csv", 6, "traverse IMU"),
            "wheels": read_numeric_csv(root / "wheels.csv", 2, "traverse wheels"),
            "groundtruth": read_numeric_csv(root / "groundtruth.csv", 16, "traverse ground truth")}
