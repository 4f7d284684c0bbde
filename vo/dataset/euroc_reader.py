"""EuRoC ASL datasets: ours (``mav0/`` + ``rig.yaml`` + ``metadata.yaml``) and real recordings.

Real EuRoC: the body frame ``B`` is the IMU frame (``imu0/sensor.yaml`` has ``T_BS = I``), so
the rig is built with ``T_b_c = T_BS`` of each camera's sensor.yaml and ``T_b_i = T_BS`` of imu0.
sensor.yaml lists 4 radtan coefficients; when a ``mav0/camchain.yaml`` (Kalibr layout, which may carry
a fifth coefficient ``k3``) is present, the distortion comes from it.
Our own datasets are read from ``rig.yaml``, which is exact and complete.
"""
from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from rigs.calib_io import read_euroc_camera_yaml, read_euroc_imu_yaml
from rigs.geometry import R_from_quat_wxyz, inv_T
from rigs.kalibr_io import read_kalibr
from rigs.model import Rig
from rigs.records import ImuSamples
from rigs.rig_yaml import load_rig
from rigs.trajectory import Trajectory
from rigs.trajfile import read_tum
from vo.dataset.base import Dataset, read_gcps_csv, read_metadata, rig_or_error
from vo.dataset.csvio import data_lines, read_image_list, read_numeric_csv
from vo.dataset.interp import interpolate_poses
from vo.errors import DatasetError

IMU_NAMES = ("w_x", "w_y", "w_z", "a_x", "a_y", "a_z")
GT_NAMES = ("p_x", "p_y", "p_z", "q_w", "q_x", "q_y", "q_z")


def pair_cameras(mav0: Path) -> tuple[np.ndarray, list, list]:
    """cam0/cam1 data.csv -> (common t_ns, [(left, right) paths], warnings); pairs by equal t_ns."""
    t0, f0 = read_image_list(mav0 / "cam0" / "data.csv")
    t1, f1 = read_image_list(mav0 / "cam1" / "data.csv")
    common, i0, i1 = np.intersect1d(t0, t1, assume_unique=True, return_indices=True)
    if len(t0) and len(t1) and not len(common):
        raise DatasetError(f"{mav0 / 'cam0' / 'data.csv'} and {mav0 / 'cam1' / 'data.csv'}: the cameras' timestamps "
                           f"do not pair: none of the {len(t0)} cam0 stamps equals one of the {len(t1)} cam1 stamps "
                           f"(first {t0[0]} and {t1[0]}, {int(t1[0]) - int(t0[0])} ns apart); a stereo frame needs "
                           f"the same timestamp on both cameras")
    warnings = []
    if len(common) < max(len(t0), len(t1)):
        warnings.append(f"dropped {len(t0) - len(common)} cam0 and {len(t1) - len(common)} cam1 frames "
                        f"without a partner at the same timestamp")
    paths = [(mav0 / "cam0" / "data" / f0[a], mav0 / "cam1" / "data" / f1[b]) for a, b in zip(i0, i1)]
    return common, paths, warnings


def real_euroc_rig(mav0: Path, name: str):
    """Rig from cam0/cam1/imu0 sensor.yaml (body = EuRoC body B, the IMU frame)."""
    cams, rate = [], None
    exact = _camchain_distortion(mav0 / "camchain.yaml")
    for k in (0, 1):
        cam, r = rig_or_error(read_euroc_camera_yaml, mav0 / f"cam{k}" / "sensor.yaml", f"cam{k}")
        cams.append(cam if exact is None else dataclasses.replace(cam, dist=exact[k][0], dist_model=exact[k][1]))
        rate = rate or r
    imu_yaml = mav0 / "imu0" / "sensor.yaml"
    imu = rig_or_error(read_euroc_imu_yaml, imu_yaml) if imu_yaml.is_file() else None
    kw = {} if imu is None else {"imu": imu}
    return rig_or_error(Rig, name=name, cameras=tuple(cams), camera_rate_hz=rate, mount="euroc", **kw)


def _camchain_distortion(path: Path):
    """[(dist, dist_model) of cam0, of cam1] from a Kalibr camchain (radtan: OpenCV 5-tuples; equidistant:
    cv2.fisheye 4-tuples), or None without one."""
    if not path.is_file():
        return None
    chain = rig_or_error(read_kalibr, path)
    if len(chain.cameras) < 2:
        raise DatasetError(f"{path}: expected cam0 and cam1, got {len(chain.cameras)} camera(s)")
    return [(c.dist, c.dist_model) for c in chain.cameras[:2]]


class EurocDataset(Dataset):
    kind = "euroc"
    images_are_rectified = False

    def __init__(self, mav0: Path, root: Path, ours: bool):
        self.mav0, self.root, self.ours = Path(mav0), Path(root), ours
        t, paths, warnings = pair_cameras(self.mav0)
        name = root.name
        if ours:
            rig = rig_or_error(load_rig, root / "rig.yaml")
            name = str(self.metadata.get("name", name))
        else:
            rig = real_euroc_rig(self.mav0, name)
        super().__init__(root, name, rig, t, paths, warnings)

    @functools.cached_property
    def metadata(self) -> dict:
        return read_metadata(self.root / "metadata.yaml") if self.ours else {}

    @functools.cached_property
    def imu(self):
        path = self.mav0 / "imu0" / "data.csv"
        if not path.is_file():
            return None
        t, v = read_numeric_csv(path, 6, "IMU", IMU_NAMES)
        return ImuSamples(t_ns=t, gyro=v[:, :3].copy(), accel=v[:, 3:].copy())

    @functools.cached_property
    def groundtruth(self):
        """``T_w_i`` (frame "i") from state_groundtruth_estimate0 (or None when absent)."""
        path = self.mav0 / "state_groundtruth_estimate0" / "data.csv"
        if not path.is_file():
            return None
        first = next(data_lines(path, "ground truth"), (0, ""))[1]
        n_values = max(len(first.split(",")) - 1, 7)
        t, v = read_numeric_csv(path, n_values, "ground truth", GT_NAMES)
        T = np.tile(np.eye(4), (len(t), 1, 1))
        T[:, :3, 3] = v[:, :3]
        T[:, :3, :3] = R_from_quat_wxyz(v[:, 3:7]) if len(t) else np.zeros((0, 3, 3))
        return Trajectory(t, T, "w", "i")

    def groundtruth_cam0(self) -> Trajectory:
        """``T_w_c0`` at frame times: ours from groundtruth_tum.txt (exact to 1e-9), otherwise the
        IMU ground truth interpolated (linear position, SLERP) composed with ``T_i_c0``."""
        tum = self.root / "groundtruth_tum.txt"
        if self.ours and tum.is_file():
            return read_tum(tum, ref="w", frame="c0")
        gt = self.groundtruth
        if gt is None:
            raise DatasetError(f"{self.mav0}: no state_groundtruth_estimate0/data.csv; no ground truth")
        T_i_c0 = inv_T(self.rig.imu.T_b_i_array) @ self.rig.cameras[0].T_b_c_array
        at_frames, _ = interpolate_poses(gt, self.frame_times_ns)
        return at_frames.transformed(np.eye(4), T_i_c0, ref="w", frame="c0")

    @functools.cached_property
    def gcps(self) -> list:
        return read_gcps_csv(self.root / "gcps.csv") if self.ours else []

    def _frame_time(self, k: int) -> int:
        if not 0 <= k < len(self):
            raise DatasetError(f"{self.path}: frame index {k} out of range [0, {len(self)})")
        return int(self.frame_times_ns[k])

    def depth(self, k: int, cam: int = 0) -> np.ndarray:
        """(H,W) float32 depth along the optical axis (m) of camera ``cam`` at frame ``k``; inf where
        nothing is in range. Reads ``<t_ns>.npy`` (exact float32 m, inf = sky) or ``<t_ns>.png``
        (uint16, 0 = no depth, returned as inf): 5000 per metre when ``metadata.yaml`` says
        ``depth_format: tum`` (TUM RGB-D), millimetres otherwise (``png16-mm``, ``png16``)."""
        import cv2
        stem = self.mav0 / f"cam{cam}" / "depth" / f"{self._frame_time(k)}"
        npy, png = stem.with_suffix(".npy"), stem.with_suffix(".png")
        if npy.is_file():
            return np.load(npy)
        if not png.is_file():
            raise DatasetError(f"{npy}: depth was not recorded for this frame/camera (no .npy or .png; "
                               f"generate the dataset with depth enabled)")
        mm = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
        if mm is None or mm.dtype != np.uint16 or mm.ndim != 2:
            raise DatasetError(f"{png}: expected a 16-bit single-channel PNG of depth")
        per_m = 5000.0 if self.metadata.get("depth_format") == "tum" else 1000.0
        depth = mm.astype(np.float32) / np.float32(per_m)
        depth[mm == 0] = np.inf
        return depth

    def segmentation(self, k: int, cam: int = 0) -> tuple:
        """``(ids (H,W) int32 with -1 background, dynamic (H,W) bool or None)`` of frame ``k``."""
        import cv2
        folder = self.mav0 / f"cam{cam}" / "segmentation"
        t = self._frame_time(k)
        path = folder / f"{t}.png"
        if not path.is_file():
            raise DatasetError(f"{path}: segmentation was not recorded for this frame/camera")
        ids = cv2.imread(str(path), cv2.IMREAD_UNCHANGED).astype(np.int32) - 1
        dyn_path = folder / f"{t}_dynamic.png"
        dyn = cv2.imread(str(dyn_path), cv2.IMREAD_UNCHANGED) != 0 if dyn_path.is_file() else None
        return ids, dyn
