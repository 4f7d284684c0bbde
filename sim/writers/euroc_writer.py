"""EuRoC ASL writer (``mav0/...``) plus our extras at the dataset root.

Layout (as the real EuRoC MAV recordings, body ``B`` = IMU frame ``S``)::

    out_dir/
      INCOMPLETE                       # only while writing
      metadata.yaml  rig.yaml  groundtruth_tum.txt (T_w_c0 at frame times)
      gcps.csv                         # only when a check point was reached (never an empty file)
      mav0/cam0/data.csv  data/<t_ns>.png  sensor.yaml (T_BS = T_i_c0; 4 radtan coefficients, k3 in a comment)
           camchain-imucam.yaml  imu.yaml             # Kalibr calibration (see below)
           cam0/depth/<t_ns>.npy                      # float32 metres along the optical axis, inf = sky
           cam0/depth/<t_ns>.png                      # or uint16: png16-mm (alias png16) mm, 0 = sky / > 65.535 m;
                                                      #   tum: 5000 per metre (TUM RGB-D), 0 = sky / > 13.107 m
           cam0/segmentation/<t_ns>.png               # uint16, object id + 1 (0 = background, id -1)
           cam0/segmentation/<t_ns>_dynamic.png       # uint8 0/1 mask (only when seg has 2 channels)
           cam1/...  imu0/data.csv  imu0/sensor.yaml (T_BS = I)
           state_groundtruth_estimate0/data.csv  sensor.yaml   # T_w_i, v_w, b_g, b_a

Floats are written with Python ``repr`` (shortest exact round trip of float64).

Calibration: ``rig.yaml`` is exact and complete. ``sensor.yaml`` lists the 4 radtan coefficients
``k1, k2, p1, p2`` as real EuRoC does, so it drops ``k3``. ``mav0/camchain-imucam.yaml`` and
``mav0/imu.yaml`` are Kalibr's files (``T_cam_imu``, ``T_cn_cnm1``, ``timeshift_cam_imu`` = the
simulated IMU clock offset ``td`` in seconds, noise densities and random walks, ``T_i_b``); Kalibr's
radtan also has 4 coefficients, so for a rig with ``k3 != 0`` (cart27) both files say in a comment
that they are not exact. ``--rig mav0/camchain-imucam.yaml --imu mav0/imu.yaml`` reads them back.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import rigs.calib_io as m
from rigs.atomic_io import atomic_write_npy, atomic_write_text
from rigs.geometry import inv_T, quat_wxyz_from_R
from rigs.kalibr_io import KALIBR_CAMCHAIN, KALIBR_IMU, write_kalibr
from rigs.rig_yaml import save_rig
from rigs.trajectory import Trajectory
from rigs.trajfile import write_tum
from sim.errors import SimError
from sim.stage_timer import NO_TIMER
from sim.writers.common import (CsvStream, PngOptions, commit_folder, config_hash, final_metadata, fmt_float,
                                prepare_folder, write_marker, write_png)

CAM_HEADER = "#timestamp [ns],filename"
IMU_HEADER = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
              "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]")
GT_HEADER = ("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
             "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
             "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
             "b_a_RS_S_z [m s^-2]")
CAM0_TRUTH_HEADER = "#timestamp [ns],T_w_c0 row-major 3x4 (12 numbers)"
DEPTH_FORMATS = ("npy", "png16-mm", "tum", "png16")
# uint16 PNG depth: counts per metre of each PNG format (png16 is the alias of png16-mm)
DEPTH_PNG_SCALE = {"png16-mm": 1000.0, "png16": 1000.0, "tum": 5000.0}
DEPTH_PNG_MAX = 65535
GCP_HEADER = "#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z"
GT_SENSOR_YAML = """# Additional sensor information
sensor_type: visual-inertial
comment: Exact simulator ground truth of the IMU frame S in the world R (z up).

# Sensor extrinsics wrt. the body-frame (the IMU frame).
T_BS:
  cols: 4
  rows: 4
  data: [1.0, 0.0, 0.0, 0.0,
         0.0, 1.0, 0.0, 0.0,
         0.0, 0.0, 1.0, 0.0,
         0.0, 0.0, 0.0, 1.0]
"""


def calib_io():
    """``rigs.calib_io`` (imported lazily)."""
    return m


def T_i_c(rig, k: int) -> np.ndarray:
    """(4,4) pose of camera ``k`` in the IMU frame: ``inv(T_b_i) @ T_b_c``."""
    return inv_T(rig.imu.T_b_i_array) @ rig.cameras[k].T_b_c_array


def _per_camera(value, n_cams: int, what: str) -> list:
    """``None`` | one array (cam0) | list of arrays/None per camera -> list of length ``n_cams``."""
    if value is None:
        return [None] * n_cams
    if isinstance(value, np.ndarray):
        return [value] + [None] * (n_cams - 1)
    value = list(value)
    if len(value) > n_cams:
        raise SimError(f"add_frame: {what} has {len(value)} entries for {n_cams} cameras")
    return value + [None] * (n_cams - len(value))


def euroc_resume_state(out_dir) -> int:
    """Frames fully written in a EuRoC folder: both csv rows (same t_ns) and both PNGs exist."""
    mav0 = Path(out_dir) / "mav0"
    rows = []
    for cam in ("cam0", "cam1"):
        p = mav0 / cam / "data.csv"
        text = p.read_text() if p.exists() else ""
        lines = [ln for ln in text.split("\n")[:-1] if ln.strip() and not ln.startswith("#")]
        rows.append(lines)
    n = 0
    for r0, r1 in zip(*rows):
        t0, f0 = r0.split(",", 1)
        t1, f1 = r1.split(",", 1)
        if t0 != t1 or not (mav0 / "cam0/data" / f0).exists() or not (mav0 / "cam1/data" / f1).exists():
            break
        n += 1
    return n


class EurocWriter:
    """Stream a stereo-inertial sequence to disk in the EuRoC ASL layout (see module docstring).

    ``rig``: a stereo ``rigs.Rig``; ``metadata``: the fully resolved configuration (plain dict,
    no wall-clock times); ``png``: how PNGs are written (:class:`sim.writers.common.PngOptions`).
    A folder with ``INCOMPLETE`` is resumed: ``self.resumed_frames`` frames are already on disk, and replayed samples at or before each stream's last row are skipped.
    """

    def __init__(self, out_dir, rig, metadata: dict, depth: bool = False, segmentation: bool = False,
                 overwrite: bool = False, depth_format: str = "npy", png: PngOptions = PngOptions()):
        if not rig.is_stereo:
            raise SimError(f"EurocWriter: rig {rig.name!r} has {len(rig.cameras)} camera(s); need 2")
        if depth_format not in DEPTH_FORMATS:
            raise SimError(f"depth_format: unknown {depth_format!r}; valid: {', '.join(DEPTH_FORMATS)}")
        self.depth_format, self.png = depth_format, png
        self.rig, self.metadata = rig, dict(metadata)
        self.depth, self.segmentation = bool(depth), bool(segmentation)
        self.out_dir, resuming = prepare_folder(out_dir, self.metadata, overwrite)
        self._hash = config_hash(self.metadata)
        self.resumed_frames = euroc_resume_state(self.out_dir) if resuming else 0
        self.mav0 = self.out_dir / "mav0"
        self._write_static_files()
        n = self.resumed_frames
        self._cams = [CsvStream(self.mav0 / f"cam{k}" / "data.csv", CAM_HEADER, resuming, keep_rows=n)
                      for k in (0, 1)]
        self._imu = CsvStream(self.mav0 / "imu0" / "data.csv", IMU_HEADER, resuming)
        self._gt = CsvStream(self.mav0 / "state_groundtruth_estimate0" / "data.csv", GT_HEADER, resuming)
        self._c0 = CsvStream(self.out_dir / "cam0_truth.csv", CAM0_TRUTH_HEADER, resuming)
        self._gcps: list = []
        self.finalized = False
        self.extra_metadata: dict = {}      # finalize() adds these keys to metadata.yaml

    # ------------------------------------------------------------------ static files
    def _write_static_files(self) -> None:
        cio = calib_io()
        for k in (0, 1):
            d = self.mav0 / f"cam{k}"
            (d / "data").mkdir(parents=True, exist_ok=True)
            if self.depth:
                (d / "depth").mkdir(exist_ok=True)
            if self.segmentation:
                (d / "segmentation").mkdir(exist_ok=True)
            cio.write_euroc_camera_yaml(d / "sensor.yaml", self.rig.cameras[k], T_i_c(self.rig, k),
                                        self.rig.camera_rate_hz, four=True)
        write_kalibr(self.rig, self.mav0 / KALIBR_CAMCHAIN, self.mav0 / KALIBR_IMU, timeshift_s=timeshift_s(self.metadata))
        (self.mav0 / "imu0").mkdir(parents=True, exist_ok=True)
        cio.write_euroc_imu_yaml(self.mav0 / "imu0" / "sensor.yaml", self.rig.imu, np.eye(4))
        atomic_write_text(self.mav0 / "state_groundtruth_estimate0" / "sensor.yaml", GT_SENSOR_YAML)
        save_rig(self.rig, self.out_dir / "rig.yaml")

    # ------------------------------------------------------------------ streams
    def add_frame(self, t_ns: int, images=None, depth=None, seg=None, files_written: bool = False) -> None:
        """Write one stereo epoch: ``images`` [left, right] (H,W) gray or (H,W,3) RGB uint8.

        ``depth``/``seg``: None, one (H,W) array for cam0, or a list per camera. ``seg`` is (H,W)
        object ids (-1 background) or (H,W,2) with channel 1 a dynamic-object mask.
        ``files_written``: the epoch's files were written by :meth:`write_frame_files` (in a worker
        thread); only the rows and the marker are added, so a frame counts once all its files exist.
        """
        t_ns = int(t_ns)
        if self._cams[0].resume_t is not None and t_ns <= self._cams[0].resume_t:
            return
        if not files_written:
            self.write_frame_files(t_ns, images, depth=depth, seg=seg)
        for cam in self._cams:
            cam.append(t_ns, [f"{t_ns}.png"])
        write_marker(self.out_dir, self._hash, f"frames={self._cams[0].rows}")

    def write_frame_files(self, t_ns: int, images, depth=None, seg=None, index: int | None = None,
                          timer=NO_TIMER) -> None:
        """The files of one epoch (images, depth, segmentation), as :meth:`add_frame`, without its rows:
        safe from several threads at once (``index``, the frame number, is not needed by this layout)."""
        t_ns = int(t_ns)
        if len(images) != 2:
            raise SimError(f"add_frame: expected 2 images (left, right), got {len(images)}")
        for k, d in enumerate(_per_camera(depth, 2, "depth")):
            if d is not None:
                if not self.depth:
                    raise SimError("add_frame: depth given but the writer was created with depth=False")
                self._write_depth(self.mav0 / f"cam{k}" / "depth", t_ns, np.asarray(d, dtype=np.float32), timer)
        for k, s in enumerate(_per_camera(seg, 2, "seg")):
            if s is not None:
                if not self.segmentation:
                    raise SimError("add_frame: seg given but the writer was created with segmentation=False")
                self._write_seg(k, t_ns, np.asarray(s), timer)
        for k in (0, 1):
            write_png(self.mav0 / f"cam{k}" / "data" / f"{t_ns}.png", images[k], png=self.png,
                      timer=timer)

    def _write_depth(self, folder: Path, t_ns: int, depth_m: np.ndarray, timer=NO_TIMER) -> None:
        """``npy``: float32 m (inf = nothing drawn); ``png16-mm`` (alias ``png16``): uint16 mm; ``tum``: uint16
        at TUM RGB-D's 5000 per metre. PNG: 0 = no depth (sky, or beyond 65535 counts)."""
        if self.depth_format == "npy":
            with timer.stage("write"):
                atomic_write_npy(folder / f"{t_ns}.npy", depth_m)
            return
        counts = np.round(depth_m.astype(np.float64) * DEPTH_PNG_SCALE[self.depth_format])
        ok = np.isfinite(counts) & (counts <= DEPTH_PNG_MAX) & (counts >= 0)
        write_png(folder / f"{t_ns}.png", np.where(ok, counts, 0).astype(np.uint16), rgb=False,
                  png=self.png, timer=timer)

    def _write_seg(self, k: int, t_ns: int, seg: np.ndarray, timer=NO_TIMER) -> None:
        folder = self.mav0 / f"cam{k}" / "segmentation"
        ids = seg[..., 0] if seg.ndim == 3 else seg
        if ids.min() < -1 or ids.max() > 65534:
            raise SimError(f"add_frame: segmentation ids must be in [-1, 65534], got [{ids.min()}, {ids.max()}]")
        write_png(folder / f"{t_ns}.png", (ids.astype(np.int64) + 1).astype(np.uint16), rgb=False,
                  png=self.png, timer=timer)
        if seg.ndim == 3:
            write_png(folder / f"{t_ns}_dynamic.png", (seg[..., 1] != 0).astype(np.uint8), rgb=False,
                      png=self.png, timer=timer)

    def add_imu(self, t_ns, gyro=None, accel=None) -> None:
        """Append IMU samples: ``t_ns`` (N,), ``gyro``/``accel`` (N,3) in the IMU frame; or one
        object with ``.t_ns, .gyro, .accel`` (rigs.records.ImuSamples). Chunks may follow each other."""
        if gyro is None and hasattr(t_ns, "gyro"):
            t_ns, gyro, accel = t_ns.t_ns, t_ns.gyro, t_ns.accel
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        g = np.asarray(gyro, dtype=float).reshape(-1, 3)
        a = np.asarray(accel, dtype=float).reshape(-1, 3)
        if not (len(t) == len(g) == len(a)):
            raise SimError(f"add_imu: t_ns, gyro, accel lengths differ: {len(t)}, {len(g)}, {len(a)}")
        for k in range(len(t)):
            self._imu.append(t[k], [fmt_float(v) for v in (*g[k], *a[k])])

    def add_groundtruth(self, t_ns, T_w_i, v_w, b_g=None, b_a=None) -> None:
        """Append ground-truth states of the IMU frame: ``T_w_i`` (N,4,4), ``v_w`` (N,3),
        biases ``b_g``/``b_a`` (N,3) (zeros when None). Quaternion written Hamilton w, x, y, z."""
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        T = np.asarray(T_w_i, dtype=float).reshape(-1, 4, 4)
        n = len(t)
        v = np.asarray(v_w, dtype=float).reshape(-1, 3)
        bg = np.zeros((n, 3)) if b_g is None else np.asarray(b_g, dtype=float).reshape(-1, 3)
        ba = np.zeros((n, 3)) if b_a is None else np.asarray(b_a, dtype=float).reshape(-1, 3)
        if not (len(T) == len(v) == len(bg) == len(ba) == n):
            raise SimError(f"add_groundtruth: lengths differ: t {n}, T {len(T)}, v {len(v)}, b_g {len(bg)}, b_a {len(ba)}")
        q = quat_wxyz_from_R(T[:, :3, :3])
        for k in range(n):
            vals = (*T[k, :3, 3], *q[k], *v[k], *bg[k], *ba[k])
            self._gt.append(t[k], [fmt_float(x) for x in vals])

    def add_cam0_truth(self, t_ns, T_w_c0) -> None:
        """Append the exact left-camera pose(s) ``T_w_c0`` (N,4,4) at frame time(s)."""
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        T = np.asarray(T_w_c0, dtype=float).reshape(-1, 4, 4)
        for k in range(len(t)):
            self._c0.append(t[k], [fmt_float(x) for x in T[k, :3, :4].reshape(-1)])

    def add_gcps(self, gcps) -> None:
        """Ground check points (list of ``vo.dataset.Gcp``); written at ``finalize()``."""
        self._gcps.extend(gcps)

    # ------------------------------------------------------------------ finish
    def finalize(self, commit: bool = True) -> Path:
        """Write gcps.csv and groundtruth_tum.txt; with ``commit`` also :meth:`commit` (metadata.yaml,
        manifest, INCOMPLETE removed). A caller that writes more files into the folder first passes
        ``commit=False`` and calls :meth:`commit` after them."""
        for s in (*self._cams, self._imu, self._gt, self._c0):
            s.close()
        gcp_note = write_gcps_csv(self.out_dir / "gcps.csv", self._gcps)
        self._write_tum()
        counts = {"n_frames": self._cams[0].rows, "n_imu": self._imu.rows, "n_groundtruth": self._gt.rows,
                  "n_gcps": len(self._gcps)}
        meta = dict(self.metadata, **self.extra_metadata, format="euroc", gcps=gcp_note,
                    calibration=calibration_note(self.rig))
        if self.depth:
            meta["depth_format"] = self.depth_format
        self.final_meta = final_metadata(meta, counts, self.rig)
        if commit:
            self.commit()
        return self.out_dir

    def commit(self) -> None:
        """The last step: metadata.yaml (``status: complete``), manifest.json, then INCOMPLETE removed."""
        commit_folder(self.out_dir, self.final_meta)
        self.finalized = True

    def _write_tum(self) -> None:
        """groundtruth_tum.txt from the streamed cam0 truth (T_w_c0), then drop the helper csv."""
        rows = [ln.split(",") for ln in self._c0.path.read_text().splitlines()[1:] if ln.strip()]
        if rows:
            t = np.array([int(r[0]) for r in rows], dtype=np.int64)
            T = np.tile(np.eye(4), (len(rows), 1, 1))
            T[:, :3, :4] = np.array([[float(x) for x in r[1:]] for r in rows]).reshape(-1, 3, 4)
            write_tum(self.out_dir / "groundtruth_tum.txt", Trajectory(t, T, "w", "c0"))
        self._c0.path.unlink()


def timeshift_s(metadata: dict) -> float:
    """Kalibr ``timeshift_cam_imu`` [s] of the written data: the configuration's ``imu_clock.time_offset_ms``
    as the integer ns the IMU stamps were shifted by (``t_imu = t_cam + td``), 0 when none is simulated."""
    clock = (metadata.get("config") or {}).get("imu_clock") or {}
    return int(round(float(clock.get("time_offset_ms", 0.0)) * 1e6)) / 1e9


def has_k3(rig) -> bool:
    return any(not c.is_fisheye and float(c.dist[4]) != 0.0 for c in rig.cameras)


def calibration_note(rig) -> str:
    """metadata.yaml ``calibration``: which calibration file is exact."""
    if has_k3(rig):
        return ("rig.yaml is exact; mav0/camK/sensor.yaml and the Kalibr mav0/camchain-imucam.yaml list 4 radtan "
                "coefficients and omit k3 (non-zero for this rig)")
    if any(c.is_fisheye for c in rig.cameras):
        return ("rig.yaml, mav0/camK/sensor.yaml (distortion_model equidistant) and the Kalibr "
                "mav0/camchain-imucam.yaml (pinhole-equi) + mav0/imu.yaml are exact (k1..k4 of cv2.fisheye)")
    return ("rig.yaml, mav0/camK/sensor.yaml and the Kalibr mav0/camchain-imucam.yaml + mav0/imu.yaml are exact "
            "(k3 = 0 for every camera)")


def write_gcps_csv(path: Path, gcps) -> str:
    """``#name,t_ns,ground_x,ground_y,ground_z,c0_x,c0_y,c0_z`` sorted as given; no file without a GCP
    (``eval --gcps`` rejects an empty one). Returns the note metadata.yaml records under ``gcps``."""
    if not gcps:
        if path.exists():
            path.unlink()
        return "none reached within the simulated duration; gcps.csv not written"
    lines = [GCP_HEADER]
    for g in gcps:
        if "," in g.name:
            raise SimError(f"gcps: name {g.name!r} must not contain a comma")
        vals = [fmt_float(x) for x in (*np.asarray(g.ground_w).reshape(3), *np.asarray(g.p_w_c0).reshape(3))]
        lines.append(",".join([g.name, str(int(g.t_ns))] + vals))
    atomic_write_text(path, "\n".join(lines) + "\n")
    return f"{len(gcps)} in gcps.csv"
