"""ROS bags as datasets: a ROS 1 ``.bag`` file or a ROS 2 bag folder (sqlite3 or MCAP), read with the
``rosbags`` library's ``AnyReader`` (no ROS installation).

Topics read (those ``vo-testbed export`` writes, as EuRoC's own bags)::

    /cam0/image_raw, /cam1/image_raw        sensor_msgs/Image mono8 | rgb8 | mono16 (stereo pairs: equal stamps)
    /cam0/camera_info, /cam1/camera_info    sensor_msgs/CameraInfo plumb_bob (K, D = k1 k2 p1 p2 [k3], P), or
                                            equidistant (D = k1 k2 k3 k4: cv2.fisheye, our dist_model equidistant)
    /tf_static                              body -> imu0, cam0, cam1 (the rig's extrinsics; identity without it)
    /imu0                                   sensor_msgs/Imu (optional); noise densities from the covariances
                                            (``density = sqrt(variance / rate)``), random walks unknown (0)
    /groundtruth/cam0                       geometry_msgs/PoseStamped T_w_c0 (optional): the ground truth

Times are the messages' ``header.stamp``. Images are read from the bag when a frame is asked for
(the reader stays open while the dataset lives). A pair is rectified when cam1's ``P[0,3] != 0``
(KITTI bags). Errors are one line naming the bag and the topic.
"""
from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from rigs.geometry import R_from_quat_wxyz
from rigs.model import Camera, Imu, Rig
from rigs.records import ImuSamples, StereoFrame
from rigs.trajectory import Trajectory
from vo.dataset.base import Dataset, rig_or_error
from vo.errors import DatasetError

IMAGE_TOPICS = ("/cam0/image_raw", "/cam1/image_raw")
INFO_TOPICS = ("/cam0/camera_info", "/cam1/camera_info")
ROS_DIST_MODELS = {"plumb_bob": "radtan", "equidistant": "equidistant"}   # sensor_msgs distortion_models.h -> ours


def is_bag(path: Path) -> bool:
    """A ROS 1 bag file (``*.bag``) or a ROS 2 bag folder (``metadata.yaml`` with ``rosbag2_bagfile_information``)."""
    path = Path(path)
    if path.is_file():
        return path.suffix == ".bag"
    meta = path / "metadata.yaml"
    if not (path.is_dir() and meta.is_file()) or (path / "mav0").exists():
        return False
    try:
        return "rosbag2_bagfile_information" in meta.read_text(encoding="utf-8", errors="replace")[:4000]
    except OSError:
        return False


def _stamp(msg) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def _field(msg, name):
    """CameraInfo arrays are ``K``/``D``/``P`` in ROS 1 and ``k``/``d``/``p`` in ROS 2."""
    return np.asarray(getattr(msg, name) if hasattr(msg, name) else getattr(msg, name.lower()), dtype=float)


def _T(translation, q) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R_from_quat_wxyz(np.array([q.w, q.x, q.y, q.z]))
    T[:3, 3] = [translation.x, translation.y, translation.z]
    return T


def image_array(msg, where: str) -> np.ndarray:
    """sensor_msgs/Image -> (H,W) uint8 grey (rgb8/bgr8 converted as the folder reader does; mono16: top 8 bits)."""
    import cv2
    enc, h, w, step = msg.encoding, int(msg.height), int(msg.width), int(msg.step)
    data = np.asarray(msg.data, dtype=np.uint8)
    if enc == "mono8":
        return data.reshape(h, step)[:, :w].copy()
    if enc == "mono16":
        dt = ">u2" if msg.is_bigendian else "<u2"
        return (data.reshape(h, step).view(dt)[:, :w] >> 8).astype(np.uint8)
    if enc in ("rgb8", "bgr8"):
        img = data.reshape(h, step)[:, :3 * w].reshape(h, w, 3)
        return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY if enc == "rgb8" else cv2.COLOR_BGR2GRAY)
    raise DatasetError(f"{where}: image encoding {enc!r} not supported (mono8, mono16, rgb8, bgr8)")


class BagDataset(Dataset):
    """A stereo(-inertial) ROS bag opened as a :class:`vo.dataset.base.Dataset` (module docstring)."""

    kind = "bag"

    def __init__(self, path):
        from rosbags.highlevel import AnyReader
        path = Path(path)
        self.root = path
        try:
            self._reader = AnyReader([path])
            self._reader.open()
        except Exception as exc:          # rosbags raises its own reader errors for damaged bags
            raise DatasetError(f"{path}: cannot open the bag: {str(exc).splitlines()[0] if str(exc) else exc}") from None
        self._conns = {c.topic: c for c in self._reader.connections}
        for topic in IMAGE_TOPICS + INFO_TOPICS:
            if topic not in self._conns:
                raise DatasetError(f"{path}: {topic}: topic missing (a stereo bag needs "
                                   f"{', '.join(IMAGE_TOPICS + INFO_TOPICS)})")
        infos = [self._camera_info(t) for t in INFO_TOPICS]
        stamps = [self._stamps(t) for t in IMAGE_TOPICS]
        common = np.intersect1d(stamps[0], stamps[1])
        warnings = []
        if len(common) < max(map(len, stamps)):
            warnings.append(f"dropped {len(stamps[0]) - len(common)} cam0 and {len(stamps[1]) - len(common)} cam1 "
                            f"images without a partner at the same stamp")
        self.images_are_rectified = abs(infos[1]["P"][3]) > 0
        rig = self._rig(infos, common)
        super().__init__(path, path.stem if path.is_file() else path.name, rig, common, [], warnings)

    # ------------------------------------------------------------------ reading
    def _messages(self, topic, start=None, stop=None):
        conn = self._conns[topic]
        for c, _, raw in self._reader.messages(connections=[conn], start=start, stop=stop):
            yield self._reader.deserialize(raw, c.msgtype)

    def _camera_info(self, topic) -> dict:
        """The first CameraInfo's size, ``K``, ``D`` and ``P``, copied at once (a deserialized message's
        arrays may view the reader's buffer, which the next read reuses)."""
        gen = self._messages(topic)
        try:
            msg = next(gen, None)
            if msg is None:
                raise DatasetError(f"{self.root}: {topic}: no message")
            model = str(msg.distortion_model or "plumb_bob")
            if model not in ROS_DIST_MODELS:
                raise DatasetError(f"{self.root}: {topic}: distortion_model: only {', '.join(ROS_DIST_MODELS)} are "
                                   f"supported, got {model!r}")
            return {"width": int(msg.width), "height": int(msg.height), "dist_model": ROS_DIST_MODELS[model],
                    **{k: _field(msg, k).copy() for k in ("K", "D", "P")}}
        finally:
            gen.close()

    def _stamps(self, topic) -> np.ndarray:
        t = np.array([_stamp(m) for m in self._messages(topic)], dtype=np.int64)
        if len(t) > 1 and np.any(np.diff(t) <= 0):
            raise DatasetError(f"{self.root}: {topic}: header stamps not strictly increasing")
        return t

    def _tf(self) -> dict:
        """{child frame id: (4,4) T_parent_child} of /tf_static (empty without it)."""
        if "/tf_static" not in self._conns:
            return {}
        return {tr.child_frame_id: _T(tr.transform.translation, tr.transform.rotation)
                for msg in self._messages("/tf_static") for tr in msg.transforms}

    def _rig(self, infos, frame_t):
        tf = self._tf()
        cams = []
        for k, info in enumerate(infos):
            K, D = info["K"].reshape(3, 3), info["D"]
            cams.append(rig_or_error(Camera, name=f"cam{k}", width=info["width"], height=info["height"],
                                     fx=K[0, 0], fy=K[1, 1], cx=K[0, 2], cy=K[1, 2], dist=tuple(D) or (0.0,) * 5,
                                     dist_model=info["dist_model"],
                                     T_b_c=tf.get(f"cam{k}", np.eye(4))))
        if self.images_are_rectified and "cam1" not in tf:     # KITTI-style: the baseline from P
            P1 = infos[1]["P"].reshape(3, 4)
            T = np.eye(4)
            T[0, 3] = -P1[0, 3] / P1[0, 0]
            cams[1] = rig_or_error(dataclasses.replace, cams[1], T_b_c=T)
        rate = float(1e9 / np.median(np.diff(frame_t))) if len(frame_t) > 1 else 10.0
        imu_kw = {"T_b_i": tf.get("imu0", np.eye(4))}
        data = self.imu
        if data is not None and len(data.t_ns) > 1:
            imu_rate = float(1e9 / np.median(np.diff(data.t_ns)))
            var_g, var_a = self._imu_variances[0]
            imu_kw.update(rate_hz=imu_rate, gyro_noise_density=float(np.sqrt(max(var_g, 0.0) / imu_rate)),
                          accel_noise_density=float(np.sqrt(max(var_a, 0.0) / imu_rate)))
        imu = rig_or_error(Imu, name="bag", **imu_kw)
        return rig_or_error(Rig, name=self.root.name, cameras=tuple(cams), imu=imu, camera_rate_hz=rate, mount="bag")

    @functools.cached_property
    def _imu_rows(self) -> list:
        """(t_ns, gyro (3,), accel (3,)) per /imu0 message, copied as read."""
        rows = []
        for m in (self._messages("/imu0") if "/imu0" in self._conns else ()):
            rows.append((_stamp(m), (m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z),
                         (m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z),
                         float(np.asarray(m.angular_velocity_covariance)[0]),
                         float(np.asarray(m.linear_acceleration_covariance)[0])))
        return rows

    @property
    def _imu_variances(self) -> list:
        return [(r[3], r[4]) for r in self._imu_rows]

    @functools.cached_property
    def imu(self):
        rows = self._imu_rows
        if not rows:
            return None
        t = np.array([r[0] for r in rows], dtype=np.int64)
        if np.any(np.diff(t) <= 0):
            raise DatasetError(f"{self.root}: /imu0: header stamps not strictly increasing")
        return ImuSamples(t, np.array([r[1] for r in rows], dtype=float), np.array([r[2] for r in rows], dtype=float))

    @functools.cached_property
    def groundtruth(self):
        if "/groundtruth/cam0" not in self._conns:
            return None
        rows = [(_stamp(m), _T(m.pose.position, m.pose.orientation)) for m in self._messages("/groundtruth/cam0")]
        t = np.array([r[0] for r in rows], dtype=np.int64)
        T = np.array([r[1] for r in rows])
        return Trajectory(t, T, ref="w", frame="c0")

    def groundtruth_cam0(self) -> Trajectory:
        if self.groundtruth is None:
            raise DatasetError(f"{self.root}: no /groundtruth/cam0 topic; no ground truth")
        return self.groundtruth

    @functools.cached_property
    def wheels(self):
        return None

    def frame(self, k: int) -> StereoFrame:
        """Stereo frame ``k``: both images read from the bag now (grey uint8)."""
        if not -len(self) <= k < len(self):
            raise DatasetError(f"{self.path}: frame index {k} out of range [0, {len(self)})")
        k = k % len(self)
        t = int(self.frame_times_ns[k])
        imgs = []
        for topic in IMAGE_TOPICS:
            gen = self._messages(topic, t - 1_000_000_000, t + 1_000_000_000)
            try:
                img = next((image_array(m, f"{self.root}: {topic}") for m in gen if _stamp(m) == t), None)
            finally:
                gen.close()
            if img is None:
                raise DatasetError(f"{self.root}: {topic}: no image stamped {t}")
            imgs.append(img)
        return StereoFrame(index=k, t_ns=t, left=imgs[0], right=imgs[1])

    def image_files(self, k: int) -> tuple:
        raise DatasetError(f"{self.root}: a bag holds images as messages, not files")

    def close(self) -> None:
        self._reader.close()

    def __del__(self):
        try:
            self._reader.close()
        except Exception:
            pass
